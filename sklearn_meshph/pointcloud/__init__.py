"""Point clouds as input: the same pipeline as meshes, on scans without connectivity.

- :mod:`.validation`: ``check_point_cloud`` (which samples are clouds is decided by
  :mod:`sklearn_meshph.inputs`);
- :mod:`.reading`: ``.xyz`` and ``.pts`` text files, and PLY files without faces;
- :mod:`.cleaning`: the cleaning policy of clouds (coincident points merged, far and
  weakly connected points dropped as other components, one connected component), in a
  canonical point order;
- :mod:`.laplacians`: ``point_cloud_laplacian`` (local Delaunay cotangent) and the
  registry ``CLOUD_LAPLACIANS``, one discretization per name of ``LAPLACIANS``;
- :mod:`.graph`: the edges of the operator's local triangles that lower-star
  persistence filters, and the symmetric kNN graph (the ``"graph"`` Laplacians');
- :mod:`._triangulation`: each point's neighbours on its own sheet of the surface, its
  tangent frame, and compiled local Delaunay triangulations.
"""

# Only what the mesh layer needs here: the Laplacians build on the spectral stage,
# which imports this package (``from sklearn_meshph import point_cloud_laplacian``).
from .validation import check_point_cloud

__all__ = ["check_point_cloud"]
