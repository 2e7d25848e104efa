"""Shape-DNA: the first Laplacian eigenvalues of a mesh as its descriptor."""

from __future__ import annotations

from numbers import Integral

import numpy as np

from .._base import SampleTransformer
from .._param_validation import Interval
from ..mesh.scalar_field import ScalarField

__all__ = ["ShapeDNA"]


class ShapeDNA(SampleTransformer):
    """The first non-constant Laplacian eigenvalues of each mesh, as features.

    Reads the ``spectrum`` that :class:`LaplacianEigenTransformer` keeps on every field
    (the eigenvalues of its one cached solve per mesh), so the spectrum comes with the
    eigenfunctions or signatures at no extra cost: solve at least ``n_eigenvalues + 1``
    eigenpairs there (``n_eigenpairs``). At unit area (``normalization="area"``) the
    eigenvalues do not depend on the mesh's scale, pose or resolution beyond
    discretization error: the "Shape-DNA" of Reuter, Wolter and Peinecke.

    Parameters
    ----------
    n_eigenvalues : int, default=30
        Eigenvalues per mesh, from the first non-constant one.

    Attributes
    ----------
    n_features_out_ : int
        ``n_eigenvalues``.

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
    >>> eigen = LaplacianEigenTransformer(signature="hks", n_eigenpairs=9)
    >>> fields = eigen.fit_transform([sphere])  # heat kernel signatures, and the spectrum
    >>> ShapeDNA(n_eigenvalues=4).fit_transform(fields).round(1)  # 4 pi * (2, 2, 2, 6)
    array([[25. , 25. , 25. , 74.6]])
    """

    _sample_kind = "scalar fields"
    _parameter_constraints: dict = {"n_eigenvalues": [Interval(Integral, 1, None, closed="left")]}

    def __init__(self, n_eigenvalues=30):
        self.n_eigenvalues = n_eigenvalues

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
        self.n_features_out_ = self.n_eigenvalues
        return self

    def transform(self, X):
        """The first ``n_eigenvalues`` non-constant eigenvalues of each field's spectrum.

        Parameters
        ----------
        X : sequence of ScalarField

        Returns
        -------
        ndarray of shape (n_samples, n_eigenvalues)
        """
        self._check_params()
        rows = []
        for i, field in enumerate(self._check_samples(X)):
            spectrum = field.spectrum if isinstance(field, ScalarField) else None
            if spectrum is None or len(spectrum) <= self.n_eigenvalues:
                have = "no spectrum" if spectrum is None else f"{len(spectrum)} eigenvalues"
                raise ValueError(
                    f"sample {i}: ShapeDNA(n_eigenvalues={self.n_eigenvalues}) needs "
                    f"{self.n_eigenvalues + 1} eigenvalues, the field has {have}; set "
                    "LaplacianEigenTransformer(n_eigenpairs=...) at least that high"
                )
            rows.append(spectrum[1 : self.n_eigenvalues + 1])
        return np.array(rows)

    def get_feature_names_out(self, input_features=None):
        """Names of the features: one per eigenvalue, from ``eigenvalue_1`` on.

        Returns
        -------
        ndarray of str
        """
        return np.array([f"eigenvalue_{k + 1}" for k in range(self.n_eigenvalues)], dtype=object)
