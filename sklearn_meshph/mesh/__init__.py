"""The mesh layer under every stage: input, validation, cleaning and ``ScalarField``.

- :mod:`.reading`: mesh files through trimesh, errors naming the file;
- :mod:`.validation`: ``check_mesh`` and the checks of faces and vertex values that
  every path to compiled code goes through;
- :mod:`.cleaning`: ``clean_mesh``, the cleaning policy;
- :mod:`.scalar_field`: ``ScalarField``, the data passed between stages;
- :mod:`._geometry`, :mod:`._graph`: compiled triangle geometry, union-find,
  connected components and the edge adjacency.
"""

from .cleaning import CleanMesh, clean_mesh
from .scalar_field import ScalarField
from .validation import check_mesh

__all__ = ["CleanMesh", "ScalarField", "check_mesh", "clean_mesh"]
