"""Shape-DNA: the first Laplacian eigenvalues of a mesh as its descriptor."""

from __future__ import annotations

import warnings
from numbers import Integral

import numpy as np
from sklearn.utils.validation import check_is_fitted

from .._base import SampleTransformer
from .._param_validation import Interval, Options
from ..mesh.scalar_field import ScalarField

__all__ = ["ShapeDNA"]


class ShapeDNA(SampleTransformer):
    """The first non-constant Laplacian eigenvalues of each mesh, as features.

    Reads the ``spectrum`` that :class:`LaplacianEigenTransformer` keeps on every field
    (the eigenvalues of its one cached solve per mesh), so the spectrum comes with the
    eigenfunctions or signatures at no extra cost. ``n_eigenpairs`` counts as the eigen
    stage's does, the constant pair included: ``ShapeDNA(n_eigenpairs=k)`` after
    ``LaplacianEigenTransformer(n_eigenpairs=k)`` gives the ``k - 1`` non-zero
    eigenvalues of its spectrum. At unit area (``normalization="area"``) the
    eigenvalues do not depend on the mesh's scale, pose or resolution beyond
    discretization error: the "Shape-DNA" of Reuter, Wolter and Peinecke.

    Parameters
    ----------
    n_eigenpairs : int, default=31
        Eigenpairs read from each spectrum, the constant one included: the features are
        the ``n_eigenpairs - 1`` eigenvalues after it.
    n_eigenvalues : int, default="deprecated"
        The former parameter, the number of features (``n_eigenpairs - 1``); giving it
        emits a ``FutureWarning`` and overrides ``n_eigenpairs``.

    Attributes
    ----------
    n_features_out_ : int
        ``n_eigenpairs - 1``.

    See Also
    --------
    FeatureDistance : Distances between the spectra (``metric="canberra"``: differences
        relative to their sum), a precomputed-metric stage.

    References
    ----------
    .. [1] M. Reuter, F.-E. Wolter and N. Peinecke, "Laplace-Beltrami spectra as
       'Shape-DNA' of surfaces and solids", Computer-Aided Design 38, 2006.

    Examples
    --------
    >>> import trimesh
    >>> from sklearn_meshph import LaplacianEigenTransformer, ShapeDNA
    >>> sphere = trimesh.creation.icosphere(3)
    >>> eigen = LaplacianEigenTransformer(signature="hks", n_eigenpairs=5)
    >>> fields = eigen.fit_transform([sphere])  # heat kernel signatures, and the spectrum
    >>> ShapeDNA(n_eigenpairs=5).fit_transform(fields).round(1)  # 4 pi * (2, 2, 2, 6)
    array([[25. , 25. , 25. , 74.6]])
    """

    _sample_kind = "scalar fields"
    _parameter_constraints: dict = {
        "n_eigenpairs": [Interval(Integral, 2, None, closed="left")],
        "n_eigenvalues": [Interval(Integral, 1, None, closed="left"), Options(("deprecated",))],
    }

    def __init__(self, n_eigenpairs=31, n_eigenvalues="deprecated"):
        self.n_eigenpairs = n_eigenpairs
        self.n_eigenvalues = n_eigenvalues

    def _count(self) -> int:
        """The eigenpairs to read, the constant one included."""
        if self.n_eigenvalues == "deprecated":
            return self.n_eigenpairs
        warnings.warn(
            f"ShapeDNA(n_eigenvalues={self.n_eigenvalues}) is renamed: write "
            f"ShapeDNA(n_eigenpairs={self.n_eigenvalues + 1}), which counts the constant "
            "pair as the eigen stage does; n_eigenvalues will be removed in a future release",
            FutureWarning,
            stacklevel=3,
        )
        return self.n_eigenvalues + 1

    def fit(self, X, y=None):
        """Check the parameters and the fields; nothing is learned.

        Parameters
        ----------
        X : sequence of ScalarField
            Fields of :class:`LaplacianEigenTransformer`, which carry a ``spectrum``.
        y : ignored

        Returns
        -------
        self
        """
        super().fit(X)
        self.n_features_out_ = self._count() - 1
        return self

    def transform(self, X):
        """The eigenvalues after the constant one in each field's first ``n_eigenpairs``.

        Parameters
        ----------
        X : sequence of ScalarField
            Each with a ``spectrum`` of at least ``n_eigenpairs`` eigenvalues.

        Returns
        -------
        ndarray of shape (n_samples, n_eigenpairs - 1)
        """
        self._check_params()
        fitted = getattr(self, "n_features_out_", None)
        count = self._count() if fitted is None else fitted + 1
        rows = []
        for i, field in enumerate(self._check_samples(X)):
            spectrum = field.spectrum if isinstance(field, ScalarField) else None
            if spectrum is None or len(spectrum) < count:
                have = "no spectrum" if spectrum is None else f"{len(spectrum)} eigenpairs"
                raise ValueError(
                    f"sample {i}: ShapeDNA(n_eigenpairs={count}) needs {count} eigenpairs, "
                    f"the field has {have}; set LaplacianEigenTransformer(n_eigenpairs=...) "
                    "at least that high"
                )
            rows.append(spectrum[1:count])
        return np.array(rows)

    def get_feature_names_out(self, input_features=None):
        """Names of the features: one per eigenvalue, from ``eigenvalue_1`` on.

        Returns
        -------
        ndarray of str
        """
        check_is_fitted(self, "n_features_out_")
        names = [f"eigenvalue_{k}" for k in range(1, self.n_features_out_ + 1)]
        return np.array(names, dtype=object)
