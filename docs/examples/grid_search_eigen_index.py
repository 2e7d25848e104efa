"""Choose the eigenfunction by grid search; the eigen cache solves each mesh once."""

import tempfile

from sklearn.model_selection import GridSearchCV, StratifiedKFold
from sklearn.neighbors import KNeighborsClassifier
from sklearn.pipeline import make_pipeline

from sklearn_meshph import (
    DiagramDistance,
    LaplacianEigenTransformer,
    LowerStarPersistence,
    make_shapes,
)

meshes, y = make_shapes(n_per_class=4, random_state=2, return_X_y=True)
with tempfile.TemporaryDirectory() as cache:
    pipe = make_pipeline(
        LaplacianEigenTransformer(memory=cache),
        LowerStarPersistence(),
        DiagramDistance(),
        KNeighborsClassifier(n_neighbors=1, metric="precomputed"),
    )
    grid = GridSearchCV(
        pipe,
        {"laplacianeigentransformer__eigen_index": [1, 2, 3, (1, 2, 3)]},
        cv=StratifiedKFold(2),
    )
    grid.fit(meshes, y)
print(grid.best_params_, round(grid.best_score_, 2))
