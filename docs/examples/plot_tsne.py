"""Embed synthetic meshes with t-SNE on the diagram distance matrix and plot it."""

import matplotlib

matplotlib.use("Agg")
from sklearn.manifold import TSNE  # noqa: E402

from sklearn_meshph import (  # noqa: E402
    DiagramDistance,
    LaplacianEigenTransformer,
    LowerStarPersistence,
    make_shapes,
)
from sklearn_meshph.plotting import plot_diagram, plot_embedding  # noqa: E402

data = make_shapes(n_per_class=5, random_state=1)
fields = LaplacianEigenTransformer().fit_transform(data.data)
persistence = LowerStarPersistence()
diagrams = persistence.fit_transform(fields)
matrix = DiagramDistance().fit_transform(diagrams)
embedding = TSNE(metric="precomputed", init="random", perplexity=8, random_state=0)
points = embedding.fit_transform(matrix)

ax = plot_embedding(points, data.target, data.target_names)
ax.figure.savefig("tsne_example.png")
ax = plot_diagram(diagrams[0], labels=persistence.diagram_names(fields[0].n_functions))
ax.figure.savefig("diagram_example.png")
print(matrix.shape, points.shape)
