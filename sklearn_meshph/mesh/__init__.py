"""The mesh layer under every stage: input, validation, cleaning and ``ScalarField``.

- :mod:`.reading`: mesh files through trimesh, errors naming the file;
- :mod:`.validation`: ``check_mesh`` and the checks of faces and vertex values that
  every path to compiled code goes through;
- :mod:`.welding`: ``weld_vertices``, one vertex per position (STL soups, OBJ seams);
- :mod:`.cleaning`: ``clean_mesh``, the cleaning policy, and its report and warning;
- :mod:`.scalar_field`: ``ScalarField``, the data passed between stages;
- :mod:`._geometry`: triangle geometry (``unit_box``, the frame every solve works in,
  and compiled areas, angles, degenerate and repeated faces);
- :mod:`.graph`: compiled union-find, connected components and the edge adjacency.
"""

from ._geometry import (
    DEGENERATE_SINE,
    smallest_angle_sines,
    triangle,
    unit_box,
    unit_box_mass,
    within_tukey_fences,
)
from .cleaning import CleaningReport, CleanMesh, MeshCleaningWarning, clean_mesh
from .scalar_field import ScalarField
from .validation import check_mesh
from .welding import weld_vertices

__all__ = [
    "DEGENERATE_SINE",
    "CleanMesh",
    "CleaningReport",
    "MeshCleaningWarning",
    "ScalarField",
    "check_mesh",
    "clean_mesh",
    "smallest_angle_sines",
    "triangle",
    "unit_box",
    "unit_box_mass",
    "within_tukey_fences",
    "weld_vertices",
]
