"""The diagram stage: validation, distances between diagrams and the distance transformer.

- :mod:`.validation`: ``check_diagram``, ``check_sample``, ``check_samples``;
- :mod:`.distances`: ``bottleneck_distance``, ``wasserstein_distance``,
  ``sliced_wasserstein_distance`` (over :mod:`._sliced`) and the registry
  ``METRICS``, over the compiled kernels :mod:`._bottleneck` (threshold search and
  minimax augmenting paths), :mod:`._wasserstein` (optimal assignment) and
  :mod:`._assignment` (what they share);
- :mod:`._batch`: packed samples and the batched loop over pairs;
- :mod:`.pairwise`: ``pairwise_diagram_distances``, blocks of pairs over joblib;
- :mod:`.transformer`: ``DiagramDistance``;
- :mod:`.per_diagram`: ``PerDiagramDistance`` (the distances of each diagram position);
- :mod:`.converters`: to and from gudhi, persim and giotto-tda.
"""

from .converters import from_giotto, from_gudhi, from_persim, to_giotto, to_gudhi, to_persim
from .distances import (
    METRICS,
    bottleneck_distance,
    sliced_wasserstein_distance,
    wasserstein_distance,
)
from .pairwise import pairwise_diagram_distances
from .per_diagram import PerDiagramDistance
from .transformer import DiagramDistance
from .validation import check_diagram, check_sample, check_samples

__all__ = [
    "METRICS",
    "DiagramDistance",
    "PerDiagramDistance",
    "bottleneck_distance",
    "check_diagram",
    "check_sample",
    "check_samples",
    "sliced_wasserstein_distance",
    "from_giotto",
    "from_gudhi",
    "from_persim",
    "pairwise_diagram_distances",
    "to_giotto",
    "to_gudhi",
    "to_persim",
    "wasserstein_distance",
]
