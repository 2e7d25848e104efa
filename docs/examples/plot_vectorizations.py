"""Persistence images and landscapes of synthetic meshes, and a linear model on them.

Writes ``vectorization_image.png`` (one persistence image) and
``vectorization_landscapes.png`` (the first landscape of two classes) to the working
folder; the documentation's pictures are made by running it in ``docs/images``.
"""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from sklearn.linear_model import LogisticRegression  # noqa: E402
from sklearn.model_selection import cross_val_score  # noqa: E402
from sklearn.pipeline import make_pipeline  # noqa: E402
from sklearn.preprocessing import StandardScaler  # noqa: E402

from sklearn_meshph import (  # noqa: E402
    LaplacianEigenTransformer,
    LowerStarPersistence,
    PersistenceImage,
    PersistenceLandscape,
    make_shapes,
)

data = make_shapes(n_per_class=6, random_state=2)
fields = LaplacianEigenTransformer(signature="log-hks", n_eigenpairs=30, n_scales=3).fit_transform(
    data.data
)
# The protrusions of the heat kernel signature at 3 times: superlevel pairs (saddle, max).
samples = LowerStarPersistence(
    filtration="extended", parts=("superlevel H0 (saddle, max)",)
).fit_transform(fields)
diagrams = [sample[0] for sample in samples]  # the earliest time, for the pictures

image = PersistenceImage(bandwidth=0.1, resolution=(40, 40), weight="persistence")
pictures = image.fit_transform(diagrams)
lo_b, hi_b, lo_p, hi_p = image.im_ranges_[0]
fig, ax = plt.subplots(figsize=(4, 3.5))
ax.imshow(
    pictures[0].reshape(40, 40), origin="lower", extent=(lo_b, hi_b, lo_p, hi_p), aspect="auto"
)
ax.scatter(diagrams[0][:, 0], diagrams[0][:, 1] - diagrams[0][:, 0], s=8, c="white")
ax.set(
    xlabel="birth",
    ylabel="persistence",
    title=f"persistence image: {data.target_names[data.target[0]]}",
)
fig.tight_layout()
fig.savefig("vectorization_image.png", dpi=110)

landscape = PersistenceLandscape(n_landscapes=1, resolution=200)
curves = landscape.fit_transform(diagrams)
fig, ax = plt.subplots(figsize=(5, 3))
for label, color in zip((0, 1), ("tab:blue", "tab:orange"), strict=True):
    for row in curves[data.target == label]:
        ax.plot(landscape.grids_[0], row, color=color, alpha=0.6, lw=1)
    ax.plot([], [], color=color, label=str(data.target_names[label]))
ax.set(xlabel="log-HKS value", ylabel="first landscape", title="landscapes of two classes")
ax.legend()
fig.tight_layout()
fig.savefig("vectorization_landscapes.png", dpi=110)

model = make_pipeline(
    PersistenceImage(bandwidth=0.1, resolution=(10, 10), weight="persistence"),
    StandardScaler(),
    LogisticRegression(max_iter=2000),
)
scores = cross_val_score(model, samples, data.target, cv=3)  # all 3 times
print(f"persistence images + logistic regression, 3-fold accuracy: {np.mean(scores):.2f}")
