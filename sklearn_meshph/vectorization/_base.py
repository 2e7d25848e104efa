"""What the vectorizers and kernels share: validated samples of diagrams, the policy for
essential points, and what ``fit`` learns per diagram position."""

from __future__ import annotations

import numpy as np
from joblib import delayed, effective_n_jobs
from sklearn.utils.validation import check_is_fitted

from .._base import SampleTransformer
from .._progress import parallel
from ..diagrams.validation import check_samples

__all__ = ["ESSENTIAL_POLICIES", "DiagramTransformer", "chunks", "finite_parts"]

ESSENTIAL_POLICIES = ("drop", "clip", "error")

# Samples per parallel task at most: bounds the memory of the rows in flight.
_CHUNK = 2048


def finite_parts(samples, policy: str, clip_values=None) -> list[tuple[np.ndarray, ...]]:
    """Samples with their essential points (death ``inf``) dropped, clipped at the
    fitted value of their position (``clip_values[k]``) or refused."""
    out = []
    for i, sample in enumerate(samples):
        parts = []
        for k, diagram in enumerate(sample):
            infinite = ~np.isfinite(diagram[:, 1])
            if infinite.any():
                if policy == "error":
                    row = int(np.flatnonzero(infinite)[0])
                    raise ValueError(
                        f"sample {i}, diagram {k}: row {row} is an essential point (death "
                        "inf); set essential='drop' or 'clip', or drop them upstream "
                        "(LowerStarPersistence(essential='drop' or 'max'))"
                    )
                if policy == "drop":
                    diagram = diagram[~infinite]
                else:
                    diagram = diagram.copy()
                    diagram[infinite, 1] = np.maximum(clip_values[k], diagram[infinite, 0])
            parts.append(diagram)
        out.append(tuple(parts))
    return out


def chunks(n: int, n_jobs) -> list[tuple[int, int]]:
    """Consecutive ``(start, stop)`` blocks of samples: a few per worker, each at most
    ``_CHUNK`` samples."""
    n_blocks = max(-(-n // _CHUNK), min(n, 4 * effective_n_jobs(n_jobs)))
    bounds = np.linspace(0, n, n_blocks + 1).astype(int)
    return [(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True) if b > a]


class DiagramTransformer(SampleTransformer):
    """Base of the transformers whose samples are persistence diagrams (one ``(n, 2)``
    array or a tuple of them, as :class:`LowerStarPersistence` returns).

    ``fit`` validates the samples, applies the ``essential`` policy (learning, for
    ``"clip"``, the largest finite death of each position) and calls ``_fit_parts`` with
    the finite diagrams of each position; ``transform`` validates, applies the policy with
    the fitted values, and computes ``_transform_part(k, diagrams)`` on blocks of samples
    in parallel (joblib), position by position, concatenating the positions' columns.
    """

    _sample_kind = "diagrams"
    _requires_fit = True

    def _fit_samples(self, X):
        """Validate and store what every vectorizer learns; returns the finite parts."""
        super().fit(X)
        samples = check_samples(X)
        self.n_diagrams_ = len(samples[0])
        deaths = [
            np.concatenate([s[k][:, 1] for s in samples] + [np.empty(0)])
            for k in range(self.n_diagrams_)
        ]
        self.clip_values_ = np.array(
            [d[np.isfinite(d)].max() if np.isfinite(d).any() else 0.0 for d in deaths]
        )
        return finite_parts(samples, self.essential, self.clip_values_)

    def _checked_parts(self, X):
        check_is_fitted(self, "n_diagrams_")
        samples = check_samples(X, n_diagrams=self.n_diagrams_)
        return finite_parts(samples, self.essential, self.clip_values_)

    def _parallel_rows(self, parts, function) -> np.ndarray:
        """``function(k, diagrams)`` for each position ``k`` on blocks of samples, as one
        ``(n_samples, n_features)`` array of ``self.dtype``."""
        n_jobs = getattr(self, "n_jobs", None)
        tasks = parallel(n_jobs)(
            delayed(_rows)(function, parts[a:b], self.n_diagrams_, self.dtype)
            for a, b in chunks(len(parts), n_jobs)
        )
        return np.vstack(list(tasks))


def _rows(function, parts, n_diagrams, dtype):
    columns = [function(k, [s[k] for s in parts]) for k in range(n_diagrams)]
    return np.hstack(columns).astype(dtype, copy=False)
