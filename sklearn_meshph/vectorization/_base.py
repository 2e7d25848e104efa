"""What the vectorizers and kernels share: the policy for infinite points, what ``fit``
learns per diagram position, the point-weight convention, the checks of parameters at
the edges of floating point, the kernels' parameters given per diagram position
(bandwidths, ``combine``, ``diagram_weights``) and how the positions' kernels combine,
and the blocks of samples of the vectorizers.

Samples are validated and packed by :func:`~sklearn_meshph.diagrams.pack_samples`, the
validator of the distances too; every transformer here works on its :class:`Packed`
samples.
"""

from __future__ import annotations

import sys
import warnings
from collections.abc import Mapping
from numbers import Real

import numpy as np
from sklearn.utils.validation import check_is_fitted

from .._base import SampleTransformer, as_sample_list, cast_output
from .._param_validation import N_JOBS, Interval, Numbers, Options
from .._progress import map_samples, sample_blocks
from ..diagrams.estimator import DiagramTransformer
from ..diagrams.validation import Packed, pack_samples

__all__ = [
    "BANDWIDTH",
    "COMBINATIONS",
    "COMBINE_PARAMETERS",
    "COMMON_CONSTRAINTS",
    "INFINITE_POLICIES",
    "WEIGHT_CONSTRAINTS",
    "WEIGHT_PARAMETER",
    "PER_POSITION",
    "PackedVectorizer",
    "PolicyTransformer",
    "apply_infinite",
    "combine_positions",
    "common_sections",
    "check_finite_output",
    "point_weights",
    "position_bandwidths",
    "position_weights",
    "resolve_range",
]

INFINITE_POLICIES = ("drop", "clip", "error")

_TINY = float(np.finfo(np.float64).tiny)
#: The bandwidths whose square, and the peak of whose 2-d Gaussian, are normal floats.
_BANDWIDTHS = (float(np.sqrt(_TINY)), float(np.sqrt(1.0 / (2.0 * np.pi * _TINY))))

#: The constraint of every ``bandwidth``: neither so small that its square underflows
#: nor so large that the Gaussian's peak does (an image or kernel of silent zeros).
BANDWIDTH = [Interval(Real, *_BANDWIDTHS, closed="both")]


class _PerPosition:
    """The constraint of a parameter given one value per diagram position: a non-empty
    1-d sequence of numbers (its length is checked against the fitted samples)."""

    def __call__(self, value) -> bool:
        # Real numbers only: "1" and True were read as 1.0 by a conversion to floats.
        # Other sequences (a range, a pandas Series) as the array of their numbers.
        if not isinstance(value, tuple | list | np.ndarray | str | bytes | Mapping):
            try:
                value = np.asarray(value)
            except (TypeError, ValueError):
                return False
        return Numbers()(value) and len(value) > 0

    def __str__(self) -> str:
        return "a sequence of floats (one per diagram position)"


PER_POSITION = _PerPosition()

#: How the kernels of the diagram positions of two samples make their kernel.
COMBINATIONS = ("product", "sum", "mean")

#: The documentation of ``combine`` and ``diagram_weights`` (the default of ``combine``
#: is the caller's), indented for a class docstring's Parameters section.
COMBINE_PARAMETERS = """combine : {{"product", "sum", "mean"}}, default="{default}"
        How the kernels ``K_k`` of the diagram positions (samples of several diagrams)
        make the kernel of two samples: their product, their weighted sum
        ``sum_k w_k K_k``, or their weighted mean (that sum divided by ``sum_k w_k``).
        Each is positive semi-definite when the ``K_k`` are.
    diagram_weights : array-like of shape (n_diagrams,), default=None
        The weights ``w_k`` of ``combine="sum"`` and ``"mean"``: finite, non-negative,
        not all 0; ``None`` gives each position the weight 1. Refused with
        ``"product"`` (give the positions their own bandwidths instead)."""


def _per_position(value, n_diagrams: int, name: str) -> np.ndarray:
    """``value`` (one number for every position, or one per position) as an array of
    ``n_diagrams`` floats, refused when its length is not ``n_diagrams``."""
    if np.ndim(value) == 0:
        return np.full(n_diagrams, float(value))
    values = np.asarray(value, dtype=np.float64)
    if len(values) != n_diagrams:
        raise ValueError(
            f"{name} has {len(values)} values for {n_diagrams} diagram positions: give one "
            "per position of the fitted samples, or a single number"
        )
    return values


def position_bandwidths(bandwidth, n_diagrams: int) -> np.ndarray:
    """The bandwidth of each diagram position, each refused (naming its position) when
    it is not finite, its square underflows or its Gaussian's peak overflows."""
    values = _per_position(bandwidth, n_diagrams, "bandwidth")
    lo, hi = _BANDWIDTHS
    bad = ~((values >= lo) & (values <= hi))  # NaN fails both
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise ValueError(
            f"bandwidth of diagram position {k} is {float(values[k])!r}: a bandwidth must be "
            f"finite and in [{lo:.3g}, {hi:.3g}] (neither so small that its square underflows "
            "nor so large that the Gaussian's peak does)"
        )
    return values


def position_weights(weights, combine: str, n_diagrams: int) -> np.ndarray:
    """The weight of each diagram position in ``combine`` (all 1 when ``weights`` is
    None), refused when negative, not finite, all 0, or given to a product."""
    if weights is None:
        return np.ones(n_diagrams)
    if combine == "product":
        raise ValueError(
            "diagram_weights weigh the terms of combine='sum' or 'mean'; a product has no "
            "terms to weigh (give each diagram position its own bandwidth instead)"
        )
    values = _per_position(weights, n_diagrams, "diagram_weights")
    bad = ~(np.isfinite(values) & (values >= 0))
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise ValueError(
            f"diagram_weights of diagram position {k} is {float(values[k])!r}: weights must be "
            "finite and non-negative"
        )
    if not values.any():
        raise ValueError("diagram_weights are all 0: the kernel would vanish")
    with np.errstate(over="ignore"):
        total = values.sum()
    if not np.isfinite(total):  # a sum of kernels of 1 would overflow, a mean be NaN
        raise ValueError(
            f"diagram_weights sum to more than float64 holds ({values.max():.3g} at most "
            "each): scale them down (a mean does not change)"
        )
    return values


def combine_positions(kernels, combine: str, weights: np.ndarray) -> np.ndarray:
    """The kernel of samples from the kernels of their diagram positions (equal-shape
    arrays, one per position, from any iterable: a generator holds one at a time),
    combined in position order."""
    kernels = iter(kernels)
    if combine == "product":
        total = next(kernels).copy()
        for values in kernels:
            total *= values
        return total
    total = weights[0] * next(kernels)
    for weight, values in zip(weights[1:], kernels, strict=True):
        total += weight * values
    return total / weights.sum() if combine == "mean" else total


#: The parameters every vectorizer and kernel has, and their constraints.
COMMON_CONSTRAINTS: dict = {
    "infinite": [Options(INFINITE_POLICIES)],
    "n_jobs": N_JOBS,
    "dtype": [Options(("float64", "float32"))],
    "essential": [Options(("deprecated", *INFINITE_POLICIES))],
}

#: Their documentation (indented for a class docstring's Parameters section).
_COMMON_PARAMETERS = """infinite : {"drop", "clip", "error"}, default="drop"
        Points with infinite death (essential classes): dropped, clipped at the largest
        finite death of their position among the fitted diagrams (at the largest
        fitted birth where there is none), or refused.
    n_jobs : int, default=None
        Number of parallel jobs (joblib). ``None`` means 1 unless in a
        :func:`joblib.parallel_backend` context; ``-1`` means all processors. Results
        are identical for any ``n_jobs``.
    dtype : {"float64", "float32"}, default="float64"
        Of the output (computed in float64).
    essential : {"drop", "clip", "error"}, optional
        Deprecated name of ``infinite`` (a :class:`FutureWarning`)."""

#: The attributes every vectorizer and kernel learns.
_COMMON_ATTRIBUTES = """n_diagrams_ : int
        Diagrams per sample.
    clip_values_ : ndarray of shape (n_diagrams,)
        Where ``infinite="clip"`` clips the deaths of each position."""


def common_sections(attributes: str = "") -> str:
    """The end of a class docstring's Parameters section (the common parameters) and
    its Attributes section (``attributes``, then the common ones), indented for it."""
    first = f"{attributes}\n    " if attributes else ""
    return (
        f"{_COMMON_PARAMETERS}\n\n    Attributes\n    ----------\n    {first}{_COMMON_ATTRIBUTES}"
    )


#: The point-weight convention of the images and the kernels.
WEIGHT_PARAMETER = """weight : {"constant", "persistence"} or callable, default="constant"
        The weight of each point ``(b, d)``: 1, its persistence ``(d - b) ** power``,
        or a function of an ``(n, 2)`` array of (birth, death) rows returning ``n``
        finite weights (called once per non-empty diagram). Weights that vanish on the
        diagonal, such as the persistence, make the result stable: points near the
        diagonal (noise) count little.
    power : float, default=1.0
        The exponent of ``weight="persistence"`` (ignored by the others)."""

WEIGHT_CONSTRAINTS: dict = {
    "weight": [Options(("constant", "persistence")), callable],
    "power": [Interval(Real, 0, None, closed="left")],
}


def point_weights(packed: Packed, starts, stops, weight, power=1.0) -> np.ndarray:
    """The weight of each (birth, death) row of the diagrams ``starts[d]:stops[d]`` of
    ``packed`` (rows outside them: 0), ``weight`` called once per non-empty diagram when
    it is a callable: the convention of :class:`PersistenceImage` and the kernels."""
    points = packed.points
    if weight == "constant":
        return np.ones(len(points))
    if weight == "persistence":
        with np.errstate(over="ignore"):
            weights = (points[:, 1] - points[:, 0]) ** float(power)
    else:
        weights = np.zeros(len(points))
        for start, stop in zip(starts, stops, strict=True):
            if stop == start:
                continue
            sample = packed.where(start).rsplit(":", 1)[0]
            try:
                values = np.asarray(weight(points[start:stop].copy()), dtype=np.float64)
            except (TypeError, ValueError) as error:
                raise ValueError(
                    f"{sample}: weight must map an (n, 2) array of (birth, death) rows to "
                    f"n numbers; its values could not be read as numbers ({error})"
                ) from error
            if values.size != stop - start:
                raise ValueError(
                    f"{sample}: weight must map an (n, 2) "
                    "array of (birth, death) rows to n finite weights; got "
                    f"{values.shape} values for {stop - start} rows"
                )
            weights[start:stop] = values.reshape(-1)
    if not np.isfinite(weights).all():
        row = int(np.flatnonzero(~np.isfinite(weights))[0])
        raise ValueError(
            f"{packed.where(row)}: its weight {weights[row]} is not finite (weights must "
            "be finite: rescale the diagrams or lower power)"
        )
    return weights


def resolve_range(given, learned, name: str) -> tuple[float, float]:
    """``(lo, hi)``: the ``given`` ends (None or NaN: the ``learned`` one), refused when
    infinite, reversed, or wider than float64 can hold."""
    given = [np.nan if g is None else float(g) for g in given]
    if any(np.isinf(g) for g in given):
        raise ValueError(f"{name} must be finite (None or NaN to learn it), got {given}")
    lo, hi = (float(learn) if np.isnan(g) else g for g, learn in zip(given, learned, strict=True))
    if lo > hi or (lo == hi and not np.isnan(given).any()):
        raise ValueError(f"{name} must go from a smaller to a larger value, got ({lo}, {hi})")
    with np.errstate(over="ignore"):
        if not np.isfinite(hi - lo):
            raise ValueError(
                f"{name} ({lo}, {hi}) is wider than float64 can hold: rescale the diagrams"
            )
    return lo, hi


def check_finite_output(values: np.ndarray, what: str, dtype=None) -> np.ndarray:
    """``values`` (one row per sample), refused if an entry overflowed or is NaN; in
    ``dtype`` when given (refused where a value does not fit it: :func:`cast_output`)."""
    bad = ~np.isfinite(values)
    if bad.any():
        i = int(np.flatnonzero(bad.any(axis=1))[0])
        raise ValueError(
            f"sample {i}: its {what} overflow float64; rescale the diagrams (or the "
            "bandwidth, or the weights)"
        )
    return values if dtype is None else cast_output(values, dtype, what)


class PolicyTransformer(DiagramTransformer):
    """Base of the vectorizers and kernels: samples validated and packed, and the
    ``infinite`` policy applied.

    ``_fit_packed(X)`` validates the samples and applies the policy (learning, for
    ``"clip"``, where to clip each position); ``_validate(X)`` does the same at
    transform time with the fitted values. Both return :class:`Packed` samples.
    """

    def _infinite_policy(self, warn: bool = False) -> str:
        """``infinite``, or ``essential`` when it is set (with a FutureWarning if
        ``warn``, as ``fit`` does)."""
        if self.essential == "deprecated":
            return self.infinite
        if warn:
            warnings.warn(
                f"{type(self).__name__}(essential=...) is renamed infinite=...; essential "
                "will be removed (LowerStarPersistence's essential keeps its meaning)",
                FutureWarning,
                stacklevel=_outside_level(),
            )
        return self.essential

    def _fit_packed(self, X) -> Packed:
        """Validate ``X``, learn the clipping value of each position (its largest finite
        death, else its largest birth) and apply the ``infinite`` policy."""
        X = as_sample_list(X, "diagrams")  # read once: X may be a generator
        SampleTransformer.fit(self, X)
        packed = pack_samples(X)  # refuses values whose sums overflow
        self.n_diagrams_ = packed.n_diagrams
        self.clip_values_ = np.array(
            [_clip_value(packed.only(k).points) for k in range(packed.n_diagrams)]
        )
        return apply_infinite(packed, self._infinite_policy(warn=True), self.clip_values_)

    def _validate(self, X) -> Packed:
        """Validate ``X`` against the fitted data and apply the ``infinite`` policy."""
        check_is_fitted(self, "n_diagrams_")
        packed = pack_samples(X, n_diagrams=self.n_diagrams_)
        return apply_infinite(packed, self._infinite_policy(), self.clip_values_)


def _outside_level() -> int:
    """The ``stacklevel`` of the first frame outside this library and scikit-learn,
    counted from the function that calls this one."""
    frame, level = sys._getframe(1), 1
    while frame is not None and frame.f_globals.get("__name__", "").split(".")[0] in (
        "sklearn_meshph",
        "sklearn",
    ):
        frame, level = frame.f_back, level + 1
    return level


def _clip_value(points: np.ndarray) -> float:
    """The largest finite death of ``points``, else their largest birth (-inf if there
    is no point: an infinite death is then clipped at its birth). Either moves with the
    diagrams: translating them translates the clipped values."""
    deaths = points[np.isfinite(points[:, 1]), 1]
    if len(deaths):
        return float(deaths.max())
    return float(points[:, 0].max()) if len(points) else -np.inf


def apply_infinite(packed: Packed, policy: str, clip_values=None) -> Packed:
    """``packed`` with its points of infinite death dropped, clipped at ``clip_values``
    (per position) or refused."""
    infinite = np.isinf(packed.points[:, 1])
    if not infinite.any():
        return packed
    if policy == "error":
        raise ValueError(
            f"{packed.where(int(np.flatnonzero(infinite)[0]))} is an essential point (death "
            "inf); set infinite='drop' or 'clip', or drop them upstream "
            "(LowerStarPersistence(essential='drop' or 'max'))"
        )
    diagram = packed.diagram_of_rows()
    if policy == "clip":
        points = packed.points.copy()
        position = diagram[infinite] % packed.n_diagrams
        points[infinite, 1] = np.maximum(np.asarray(clip_values)[position], points[infinite, 0])
        return Packed(points, packed.offsets, packed.n_diagrams)
    keep = ~infinite
    offsets = np.zeros_like(packed.offsets)
    np.cumsum(np.bincount(diagram[keep], minlength=len(offsets) - 1), out=offsets[1:])
    return Packed(np.ascontiguousarray(packed.points[keep]), offsets, packed.n_diagrams)


class PackedVectorizer(PolicyTransformer):
    """Base of the vectorizers: samples packed once, ``_fit_positions(packed)`` learns
    per position, ``_compute(k, packed, starts, stops)`` gives the block of columns of
    position ``k`` for the diagrams ``starts:stops`` of ``packed.points``; a sample's
    features are the columns of each of its diagrams, position after position."""

    _output_name = "features"

    def _fit(self, X) -> Packed:
        packed = self._fit_packed(X)
        self._fit_positions(packed)
        return packed

    def _fit_output(self, packed: Packed) -> np.ndarray:
        return self._rows(packed)

    def _output(self, packed: Packed) -> np.ndarray:
        return self._rows(packed)

    def _rows(self, packed: Packed) -> np.ndarray:
        # The compiled loops release the GIL: threads, unless a parallel_backend says
        # otherwise (then each task carries only its block of samples).
        blocks = sample_blocks(packed.n_samples, self.n_jobs)
        if len(blocks) == 1:
            rows = [self._block_rows(packed)]
        else:
            parts = (packed.block(a, b) for a, b in blocks)
            rows = map_samples(self._block_rows, parts, n_jobs=self.n_jobs, prefer="threads")
        return check_finite_output(np.vstack(rows), self._output_name, self.dtype)

    def _block_rows(self, packed: Packed) -> np.ndarray:
        columns = [self._compute(k, packed, *packed.position(k)) for k in range(packed.n_diagrams)]
        return np.hstack(columns)
