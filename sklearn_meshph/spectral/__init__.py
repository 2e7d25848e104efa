"""The spectral stage: Laplacians of meshes, clouds and graphs, their eigenpairs and the
eigen transformer.

- :mod:`.laplacians`: ``cotangent_laplacian``, ``graph_laplacian`` and the registries
  ``LAPLACIANS`` and ``GRAPH_LAPLACIANS`` (graph samples);
- :mod:`.eigensolver`: shift-invert Lanczos (:mod:`.lanczos`, checked by an inertia
  count; ARPACK where the check fails), the dense path, sign rule,
  ``laplacian_eigenfunctions``;
- :mod:`.factorization`: the factorization backends (registry ``SOLVERS``) over
  :mod:`._cholesky` (our supernodal Cholesky, its solves in :mod:`._triangular`) and
  SciPy's SuperLU, with the
  fill-reducing order of :mod:`._ordering`;
- :mod:`.solve`: one sample's cleaning and eigensolve in the unit box (a graph's: its
  components), the unit of work the cache stores;
- :mod:`.cache`: the eigen cache (data-only entries, checked on read);
- :mod:`.signatures`: heat and wave kernel signatures of the eigenpairs (registry
  ``SIGNATURES``);
- :mod:`.quality`: the needle-triangle check, ``MeshQualityWarning``;
- :mod:`.multiplicity`: repeated eigenvalues, ``RepeatedEigenvalueWarning``;
- :mod:`.shape_dna`: ``ShapeDNA``, the spectrum as a feature vector;
- :mod:`.transformer`: ``LaplacianEigenTransformer``.
"""

from .cache import CacheWarning
from .eigensolver import laplacian_eigenfunctions
from .factorization import SOLVERS
from .laplacians import GRAPH_LAPLACIANS, LAPLACIANS, cotangent_laplacian, graph_laplacian
from .multiplicity import RepeatedEigenvalueWarning
from .quality import MeshQualityWarning
from .shape_dna import ShapeDNA
from .signatures import SIGNATURES
from .transformer import ConstantEigenfunctionWarning, LaplacianEigenTransformer

__all__ = [
    "CacheWarning",
    "GRAPH_LAPLACIANS",
    "LAPLACIANS",
    "SIGNATURES",
    "SOLVERS",
    "ConstantEigenfunctionWarning",
    "LaplacianEigenTransformer",
    "MeshQualityWarning",
    "RepeatedEigenvalueWarning",
    "ShapeDNA",
    "cotangent_laplacian",
    "graph_laplacian",
    "laplacian_eigenfunctions",
]
