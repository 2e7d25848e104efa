"""Small helpers shared by the estimators."""

from __future__ import annotations

import functools
import os
from collections.abc import Sequence

import numpy as np
from threadpoolctl import ThreadpoolController


@functools.cache
def _controller() -> ThreadpoolController:
    return ThreadpoolController()


def one_blas_thread():
    """Context limiting BLAS to one thread.

    With the process's controller made once, entering costs about 20 us, against 2 ms
    for ``threadpool_limits``, which looks up the loaded libraries each time.
    """
    return _controller().limit(limits=1, user_api="blas")


def as_sample_list(X, what: str = "meshes") -> list:
    """``X`` as a list of samples, refusing a single sample passed by mistake."""
    if isinstance(X, np.ndarray) and X.dtype == object and X.ndim == 1:
        X = list(X)
    if isinstance(X, str | bytes | os.PathLike | np.ndarray) or hasattr(X, "vertices"):
        raise TypeError(
            f"X must be a sequence of {what} (one per sample), got a single "
            f"{type(X).__name__}; wrap it in a list"
        )
    if not isinstance(X, Sequence) and not hasattr(X, "__iter__"):
        raise TypeError(f"X must be a sequence of {what}, got {type(X).__name__}")
    samples = list(X)
    if not samples:
        raise ValueError(f"X is empty: expected at least one of {what}")
    return samples


def sequence_input_tags(tags, *, requires_fit: bool):
    """Tags of a transformer whose samples are meshes, fields or diagrams, not rows."""
    tags.requires_fit = requires_fit
    tags.input_tags.two_d_array = False
    tags.transformer_tags.preserves_dtype = []
    return tags
