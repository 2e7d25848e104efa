"""The persistence stage: diagrams of lower-star filtrations of vertex functions.

- :mod:`.lower_star`: sublevel H0 by union-find, ``lower_star_persistence``;
- :mod:`.extended`: the essential H1 classes of closed surfaces (extended persistence);
- :mod:`.filtrations`: the registry ``FILTRATIONS`` of what one function contributes;
- :mod:`.graph_extended`: the four extended diagrams of a function on a graph,
  ``extended_persistence``;
- :mod:`.transformer`: ``LowerStarPersistence``.
"""

from .filtrations import FILTRATIONS
from .graph_extended import extended_persistence
from .lower_star import lower_star_persistence
from .transformer import LowerStarPersistence

__all__ = [
    "FILTRATIONS",
    "LowerStarPersistence",
    "extended_persistence",
    "lower_star_persistence",
]
