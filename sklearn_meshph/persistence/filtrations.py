"""The filtrations of a vertex function: the registry read by ``LowerStarPersistence``.

Each entry computes the diagrams of one function from the mesh's edge adjacency (built
once per mesh) and names them. A new filtration is a function
``(adjacency, values, essential, surface, wanted) -> list of (n, 2) arrays``, the names
and short ids of its diagrams and one :class:`Filtration` entry in :data:`FILTRATIONS`.
``surface`` is a closed surface's edge structure (:func:`.extended.closed_surface`),
built once per mesh when a diagram that needs it is wanted, or None. ``wanted`` holds
the indices of the diagrams the caller keeps: a filtration may skip the work of the
others and return them empty.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .._registry import Option, Registry
from ..mesh.graph import connected_components
from .extended import essential_h1_pairs
from .lower_star import sublevel_h0

__all__ = ["ESSENTIAL_POLICIES", "FILTRATIONS", "Filtration", "function_diagrams"]

ESSENTIAL_POLICIES = ("keep", "drop", "max")


@dataclass(frozen=True)
class Filtration:
    """How one function becomes diagrams: ``compute``, and the name and short id of
    each diagram (``LowerStarPersistence(parts=...)`` takes either).

    ``surface_diagrams``: the indices of the diagrams that ``compute`` makes from the
    closed-surface edge structure (built once per mesh when one of them is wanted, None
    on a mesh that is not a closed surface). ``from_graph``: the diagrams of a graph
    sample are those of :func:`.graph_extended.batch_diagrams` (the whole of its
    extended persistence, for many graphs at once), not ``compute``'s.
    """

    compute: Callable
    diagram_names: tuple[str, ...]
    diagram_ids: tuple[str, ...]
    surface_diagrams: tuple[int, ...] = ()
    from_graph: bool = False

    def positions(self, parts) -> list[int]:
        """Positions, in output order, of the diagrams named by ``parts`` (ids or names);
        a ``ValueError`` listing both for anything else."""
        unknown = [p for p in parts if p not in self.diagram_ids + self.diagram_names]
        if unknown or not parts:
            raise ValueError(
                f"parts must be a non-empty tuple of ids {self.diagram_ids} or names "
                f"{self.diagram_names} of this filtration's diagrams; got {tuple(parts)!r}"
            )
        pairs = zip(self.diagram_names, self.diagram_ids, strict=True)
        return [k for k, (name, short) in enumerate(pairs) if name in parts or short in parts]


def _reflect(diagram: np.ndarray) -> np.ndarray:
    """The pairs of ``-f`` from those of ``f``: (b, d) -> (-d, -b)."""
    return np.column_stack([-diagram[:, 1], -diagram[:, 0]])


def _component_extremes(values, roots, adjacency):
    """(min, max) of each connected component, in the order of the minima's ranks."""
    n = adjacency.shape[0]
    ends = np.column_stack([np.repeat(np.arange(n), np.diff(adjacency.indptr)), adjacency.indices])
    _, labels = connected_components(n, ends)
    maxima = np.full(labels.max() + 1, -np.inf)
    np.maximum.at(maxima, labels, values)
    return np.column_stack([values[roots], maxima[labels[roots]]])


def _essential(births, values, roots, adjacency, policy):
    if policy == "drop":
        return np.empty((0, 2))
    if policy == "max":
        return _component_extremes(values, roots, adjacency)
    return np.column_stack([births, np.full(len(births), np.inf)])


def _sublevel(adjacency, values, essential, surface, wanted):
    pairs, births, roots = sublevel_h0(adjacency, values)
    return [np.vstack([pairs, _essential(births, values, roots, adjacency, essential)])]


def _superlevel(adjacency, values, essential, surface, wanted):
    return _sublevel(adjacency, -values, essential, surface, wanted)


def _both_sweeps(adjacency, values):
    sub, _, roots = sublevel_h0(adjacency, values)
    sup, _, _ = sublevel_h0(adjacency, -values)
    return sub, sup, _component_extremes(values, roots, adjacency)


def _symmetric(adjacency, values, essential, surface, wanted):
    sub, sup, extremes = _both_sweeps(adjacency, values)
    return [np.vstack([sub, sup]), np.vstack([extremes, _reflect(extremes)])]


def _extended(adjacency, values, essential, surface, wanted):
    sub = sup = extremes = ext1 = np.empty((0, 2))
    if 0 in wanted or 2 in wanted:
        sub, _, roots = sublevel_h0(adjacency, values)
        if 2 in wanted:
            extremes = _component_extremes(values, roots, adjacency)
    if 1 in wanted:
        sup = _reflect(sublevel_h0(adjacency, -values)[0])
    if 3 in wanted and surface is not None:
        ext1 = essential_h1_pairs(values, surface)
        ext1 = ext1[ext1[:, 0] < ext1[:, 1]]
    return [sub, sup, extremes, ext1]


FILTRATIONS = Registry(
    "filtration",
    [
        Option(
            "symmetric",
            Filtration(_symmetric, ("H0(f) + H0(-f)", "(min, max) + reflected"), ("h0", "ext0")),
            "two diagrams: `h0`, `H0(f) + H0(-f)` merged, and `ext0`, each component's "
            "`(min, max)` with its reflection; `f` and `-f` give identical output (the "
            "default)",
        ),
        Option(
            "sublevel",
            Filtration(_sublevel, ("sublevel H0",), ("h0",)),
            "`h0`, the sublevel H0 of `f`, essential classes by `essential`; depends on the sign "
            "(the paper's setting)",
        ),
        Option(
            "superlevel",
            Filtration(_superlevel, ("superlevel H0",), ("h0",)),
            "`h0`, the sublevel H0 of `-f` (superlevel sets of `f`), essential classes by "
            "`essential`; depends on the sign",
        ),
        Option(
            "extended",
            Filtration(
                _extended,
                ("ordinary H0", "superlevel H0 (saddle, max)", "(min, max)", "essential H1"),
                ("ord0", "ord1", "ext0", "ext1"),
                surface_diagrams=(3,),
                from_graph=True,
            ),
            "four diagrams of extended persistence: `ord0` (min, saddle) pairs, `ord1` "
            "superlevel (saddle, max) pairs, `ext0` each component's (min, max) and `ext1` "
            "the essential H1 of a closed surface (`Ext1+`) or a graph's cycles as "
            "(min, max); `-f` swaps the first two and reflects all",
        ),
    ],
)


def function_diagrams(
    adjacency, values, *, filtration, essential, min_persistence, surface=None, wanted=None
):
    """The diagrams of one function, as a list of (n, 2) arrays (see LowerStarPersistence).

    ``surface`` (from :func:`.extended.closed_surface`, built once per mesh) enables the
    essential H1 diagram of ``"extended"``; without it that diagram is empty. ``wanted``
    (indices; ``None``: all) are the diagrams the caller keeps, the others may be empty.
    """
    entry = FILTRATIONS[filtration].value
    wanted = range(len(entry.diagram_names)) if wanted is None else wanted
    diagrams = entry.compute(adjacency, values, essential, surface, wanted)
    # Also drops the (min, max) pair of a component where the function is constant.
    return [d[(d[:, 1] - d[:, 0]) > min_persistence] for d in diagrams]
