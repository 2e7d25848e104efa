"""Spectral signatures: vertex functions made from the eigenpairs of one solve.

Each signature is a function ``(eigenvalues, eigenvectors, size) -> (values, names)`` of
the first eigenpairs of ``L phi = lambda M phi`` (M-orthonormal eigenvectors, the
constant one first), ``values`` of shape ``(n_vertices, size)`` and ``names`` a label
per column (``"heat kernel signature t=0.0312"``), and one entry in :data:`SIGNATURES`:

- ``"hks"``, the heat kernel signature ``sum_k exp(-lambda_k t) phi_k(x)^2`` (Sun,
  Ovsjanikov and Guibas, 2009) at ``size`` times, or at the fixed times ``size`` holds
  when it is an array (:func:`check_times`; PersLay's ``t = 0.1, 10`` on graphs);
- ``"log-hks"``, ``log(HKS(x, t) / sum_k exp(-lambda_k t))``: the HKS over its mean on
  the unit-area surface, in log scale, so that every time's column is on the same
  footing;
- ``"wks"``, the wave kernel signature (Aubry, Schlickewei and Cremers, 2011): the
  probability of a quantum particle of log-energy ``e`` to be at ``x``, at ``size``
  energies.

Both are sums of squared eigenfunctions weighted by a function of the eigenvalue, so
they do not depend on the sign of any eigenvector, nor on the basis chosen inside a
repeated eigenspace (``sum phi_k(x)^2`` over an orthonormal basis of an eigenspace is
the same for every basis). Times and energies are chosen from the eigenvalues
themselves, so on a unit-area mesh (``normalization="area"``) the signatures do not
depend on the mesh's scale either.
"""

from __future__ import annotations

import numpy as np

from .._registry import Option, Registry

__all__ = [
    "HEAT_SIGNATURES",
    "MAX_SCALES",
    "MAX_TIME",
    "MIN_TIME",
    "SIGNATURES",
    "check_times",
    "heat_kernel_signature",
    "hks_times",
    "wave_kernel_signature",
    "wks_energies",
]

#: The signatures that take fixed times (``LaplacianEigenTransformer(times=...)``).
HEAT_SIGNATURES = ("hks", "log-hks")
#: The range of fixed times: float64's square-root range, so that ``lambda * t`` is
#: neither negligible nor overflowing for any eigenvalue within the same range.
MIN_TIME, MAX_TIME = 1e-150, 1e150

# Log-energy spread of each wave kernel band, in units of the step between energies
# (Aubry et al. use 6 to 7 steps).
_WKS_WIDTH = 6.0


def _positive(eigenvalues: np.ndarray) -> np.ndarray:
    """The eigenvalues after the constant one (the first, about 0)."""
    if len(eigenvalues) < 2 or not eigenvalues[1] > 0:
        raise ValueError("a spectral signature needs at least one positive eigenvalue")
    return eigenvalues[1:]


def hks_times(eigenvalues: np.ndarray, size: int) -> np.ndarray:
    """``size`` times, log-spaced from ``4 ln 10 / lambda_max`` to ``4 ln 10 / lambda_1``.

    The rule of Sun et al.: at the first time the largest eigenvalue's term has decayed
    by 10^4, at the last the first non-constant one's. Relative to the eigenvalues, so
    scale-free at unit area.
    """
    positive = _positive(eigenvalues)
    span = 4.0 * np.log(10.0) / np.array([positive[-1], positive[0]])
    return np.geomspace(span[0], span[1], size) if size > 1 else span[1:]


#: Most times or energies of a signature (``n_scales``, or fixed ``times``): each is a
#: column per vertex, and a thousand is already far finer than the spectrum resolves.
MAX_SCALES = 1024


def check_times(times) -> np.ndarray:
    """Fixed times of a heat signature as a 1-D float64 array: not empty, each finite and
    within ``[MIN_TIME, MAX_TIME]``; a ``ValueError`` saying what is wrong otherwise."""
    kind = np.asarray(times).dtype.kind
    if kind not in "iuf":
        raise ValueError(f"times must be an array of positive numbers, got {times!r}")
    array = np.asarray(times, dtype=np.float64)
    if array.ndim != 1 or array.size == 0:
        raise ValueError(f"times must be a non-empty 1-D array of times, got shape {array.shape}")
    if array.size > MAX_SCALES:
        raise ValueError(f"times holds {array.size} times, more than MAX_SCALES ({MAX_SCALES})")
    bad = ~((array >= MIN_TIME) & (array <= MAX_TIME))  # NaN included
    if bad.any():
        raise ValueError(
            f"times must be finite and between {MIN_TIME:g} and {MAX_TIME:g}, got "
            f"{float(array[bad][0])!r} (beyond that range every exp(-lambda t) is 0 or 1 for the "
            "eigenvalues float64 holds: a signature without information)"
        )
    return array


def _times(eigenvalues, size) -> np.ndarray:
    """``size`` times chosen from the eigenvalues, or ``size`` itself if it is an
    array of fixed times."""
    return hks_times(eigenvalues, size) if np.ndim(size) == 0 else check_times(size)


def heat_kernel_signature(eigenvalues, eigenvectors, times) -> np.ndarray:
    """``HKS(x, t) = sum_k exp(-lambda_k t) phi_k(x)^2``, one column per time.

    Parameters
    ----------
    eigenvalues : ndarray of shape (k,)
    eigenvectors : ndarray of shape (n_vertices, k)
        M-orthonormal eigenvectors.
    times : array-like of shape (m,)

    Returns
    -------
    ndarray of shape (n_vertices, m)

    Examples
    --------
    >>> import numpy as np
    >>> values = np.array([0.0, 2.0])
    >>> vectors = np.array([[1.0, 1.0], [1.0, -1.0]])
    >>> heat_kernel_signature(values, vectors, [0.0, np.log(2.0)])
    array([[2.  , 1.25],
           [2.  , 1.25]])
    """
    values = np.asarray(eigenvalues, dtype=np.float64)
    weights = np.exp(-np.outer(values, np.asarray(times, dtype=np.float64)))
    return (np.asarray(eigenvectors) ** 2) @ weights


def wks_energies(eigenvalues: np.ndarray, size: int) -> tuple[np.ndarray, float]:
    """``size`` log-energies between ``log lambda_1`` and ``log lambda_max``, and the
    width of each band (``6`` steps, at least a fortieth of the range)."""
    log_values = np.log(_positive(eigenvalues))
    low, high = log_values[0], log_values[-1]
    energies = np.linspace(low, high, size + 2)[1:-1] if size > 1 else np.array([low])
    step = (high - low) / (size + 1)
    return energies, max(_WKS_WIDTH * step, (high - low) / 40.0, 1e-12)


def wave_kernel_signature(eigenvalues, eigenvectors, energies, sigma) -> np.ndarray:
    """``WKS(x, e) = sum_k phi_k(x)^2 g_e(lambda_k) / sum_k g_e(lambda_k)`` over the
    non-constant eigenpairs, ``g_e(lambda) = exp(-(e - log lambda)^2 / (2 sigma^2))``.

    Parameters
    ----------
    eigenvalues : ndarray of shape (k,)
        Ascending, the first (the constant eigenfunction's) is skipped.
    eigenvectors : ndarray of shape (n_vertices, k)
    energies : array-like of shape (m,)
        Log-energies.
    sigma : float
        Width of each band in log-energy.

    Returns
    -------
    ndarray of shape (n_vertices, m)
    """
    log_values = np.log(_positive(np.asarray(eigenvalues, dtype=np.float64)))
    gaps = np.asarray(energies, dtype=np.float64)[None, :] - log_values[:, None]
    weights = np.exp(-(gaps**2) / (2.0 * sigma**2))
    weights /= weights.sum(axis=0, keepdims=True)
    return (np.asarray(eigenvectors)[:, 1:] ** 2) @ weights


def _labels(name: str, symbol: str, scales) -> tuple[str, ...]:
    return tuple(f"{name} {symbol}={scale:.3g}" for scale in scales)


def _hks(eigenvalues, eigenvectors, size):
    times = _times(eigenvalues, size)
    hks = heat_kernel_signature(eigenvalues, eigenvectors, times)
    return hks, _labels("heat kernel signature", "t", times)


def _log_hks(eigenvalues, eigenvectors, size):
    """``log(HKS(x, t) / trace(t))``, the heat trace ``sum_k exp(-lambda_k t)`` being the
    HKS's mean over the unit-area surface: each time's column is centred on 0 in log
    scale, so the times weigh alike in a distance."""
    times = _times(eigenvalues, size)
    hks = heat_kernel_signature(eigenvalues, eigenvectors, times)
    trace = np.exp(-np.outer(np.asarray(eigenvalues, dtype=np.float64), times)).sum(axis=0)
    log_hks = np.log(np.maximum(hks, np.finfo(float).tiny) / trace)
    return log_hks, _labels("log heat kernel signature", "t", times)


def _wks(eigenvalues, eigenvectors, size):
    energies, sigma = wks_energies(eigenvalues, size)
    wks = wave_kernel_signature(eigenvalues, eigenvectors, energies, sigma)
    return wks, _labels("wave kernel signature", "e", energies)


SIGNATURES = Registry(
    "signature",
    [
        Option(
            "eigenfunctions",
            None,
            "the eigenfunctions of `eigen_index` themselves (the paper's functions; sign "
            "fixed by a rule, not unique for a repeated eigenvalue)",
        ),
        Option(
            "hks",
            _hks,
            "heat kernel signature at `n_scales` times log-spaced from `4 ln 10 / "
            "lambda_max` to `4 ln 10 / lambda_1`; independent of signs and of the basis "
            "of repeated eigenspaces",
        ),
        Option(
            "log-hks",
            _log_hks,
            "log of the heat kernel signature over the heat trace (its mean on the "
            "unit-area surface), at the times of `hks`: each time centred in log scale",
        ),
        Option(
            "wks",
            _wks,
            "wave kernel signature at `n_scales` log-energies between `log lambda_1` and "
            "`log lambda_max`; independent of signs and of the basis of repeated "
            "eigenspaces",
        ),
    ],
)
