"""Plotting helpers (matplotlib, the optional ``plot`` extra)."""

from __future__ import annotations

import os

import numpy as np

__all__ = ["plot_diagram", "plot_embedding", "plot_mesh_function", "pyplot"]


def pyplot():
    """``matplotlib.pyplot``, rendering to files (the Agg backend) when there is no
    screen and no ``MPLBACKEND``; an ``ImportError`` saying which extra to install
    without matplotlib."""
    try:
        import matplotlib

        if not os.environ.get("DISPLAY") and not os.environ.get("MPLBACKEND"):
            matplotlib.use("Agg")  # no screen: render to files
        import matplotlib.pyplot as plt
    except ImportError as exc:
        raise ImportError("plotting needs matplotlib: pip install 'sklearn-meshph[plot]'") from exc
    return plt


def _axes(ax, **kwargs):
    if ax is not None:
        return ax
    return pyplot().figure(figsize=(5, 4.5)).add_subplot(**kwargs)


def plot_diagram(diagram, ax=None, *, labels=None, title=None):
    """Draw a persistence diagram, or the diagrams of a tuple in several colours.

    Parameters
    ----------
    diagram : ndarray of shape (n, 2), or tuple or list of them
        Rows (birth, death); infinite deaths are drawn on a line above the points,
        marked ``inf``. A list of ``(birth, death)`` pairs is one diagram; a list whose
        entries are 2-D arrays is several. NaN is refused (it is no point).
    ax : matplotlib Axes, optional
    labels : sequence of str, optional
        Legend entries of the diagrams, one each (default: ``diagram 0``, ...).
    title : str, optional

    Returns
    -------
    ax : matplotlib Axes
    """
    diagrams = _diagrams_to_plot(diagram)
    if labels is not None and len(labels) != len(diagrams):
        raise ValueError(f"labels holds {len(labels)} entries for {len(diagrams)} diagrams")
    ax = _axes(ax)
    finite = np.concatenate([d[np.isfinite(d)] for d in diagrams] + [np.zeros(0)])
    lo, hi = (finite.min(), finite.max()) if finite.size else (0.0, 1.0)
    pad = 0.05 * (hi - lo or 1.0)
    inf_level = hi + 4 * pad
    # A (colour, marker) per diagram, distinct for up to 100 (the colour cycle and the
    # markers both repeated after 10: diagrams 0 and 10 looked alike).
    colors = pyplot().get_cmap("tab10").colors
    markers = "osD^v<>p*h"
    for k, d in enumerate(diagrams):
        deaths = np.where(np.isfinite(d[:, 1]), d[:, 1], inf_level)
        label = labels[k] if labels is not None else f"diagram {k}" if len(diagrams) > 1 else None
        if not len(d) and label is not None:
            label = f"{label} (empty)"
        style = {"color": colors[k % 10], "marker": markers[(k // 10 + k) % len(markers)]}
        ax.scatter(d[:, 0], deaths, s=18, label=label, alpha=0.8, **style)
    ax.plot([lo - pad, inf_level], [lo - pad, inf_level], color="0.5", lw=0.8)
    if any((~np.isfinite(d[:, 1])).any() for d in diagrams):
        ax.axhline(inf_level, color="0.5", lw=0.8, ls="--")
        ax.text(lo - pad, inf_level, " inf", va="bottom", fontsize=8)
    ax.set_xlabel("birth")
    ax.set_ylabel("death")
    if len(diagrams) > 5:  # beside the axes, not over the points
        ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.02, 0.5))
    elif len(diagrams) > 1:
        ax.legend(fontsize=7, loc="lower right")
    if title:
        ax.set_title(title)
    return ax


def _diagrams_to_plot(diagram) -> list[np.ndarray]:
    """The diagrams of ``plot_diagram``'s argument, each checked: ``(n, 2)`` (an empty
    one of any shape), no NaN. Other shapes were reshaped into made-up points (giotto-tda's
    ``(n, 3)`` rows among them), and a NaN death drawn as an essential class."""
    several = isinstance(diagram, tuple) or (
        isinstance(diagram, list) and len(diagram) > 0 and all(np.ndim(d) == 2 for d in diagram)
    )
    diagrams = []
    for k, d in enumerate(diagram if several else [diagram]):
        d = np.asarray(d, dtype=float)
        place = f"diagram {k}" if several else "the diagram"
        if d.size == 0:
            d = d.reshape(0, 2)
        elif d.shape == (2,):  # one (birth, death) point
            d = d.reshape(1, 2)
        elif d.ndim != 2 or d.shape[1] != 2:
            raise ValueError(f"{place} must have shape (n, 2) (birth, death), got {d.shape}")
        nan = np.flatnonzero(np.isnan(d).any(axis=1))
        if len(nan):
            raise ValueError(f"{place}: row {nan[0]} holds NaN, which is no point")
        diagrams.append(d)
    return diagrams


def _class_styles(n_classes: int):
    """A (colour, marker) per class: distinct for up to 10 classes by colour alone
    (tab10), beyond that tab20 colours combined with a cycle of markers."""
    plt = pyplot()
    markers = "o"
    colors = plt.get_cmap("tab10").colors
    if n_classes > 10:
        colors = plt.get_cmap("tab20").colors
        markers = "osD^vP*Xph<>"
    return [
        (colors[c % len(colors)], markers[(c // len(colors) + c) % len(markers)])
        for c in range(n_classes)
    ]


def plot_embedding(embedding, labels, target_names=None, ax=None):
    """Scatter a 2-D embedding (e.g. t-SNE of a distance matrix) coloured by class.

    Up to 10 classes are told apart by colour; more by colour and marker (tab20 and a
    cycle of markers). The legend is placed outside the axes, on their right, in
    several columns for many classes.

    Parameters
    ----------
    embedding : ndarray of shape (n, 2)
    labels : array-like of shape (n,)
        Integer class labels.
    target_names : sequence of str, optional
    ax : matplotlib Axes, optional

    Returns
    -------
    ax : matplotlib Axes
    """
    embedding = np.asarray(embedding)
    labels = np.asarray(labels)
    if embedding.ndim != 2 or embedding.shape[1] != 2 or len(labels) != len(embedding):
        raise ValueError(
            f"embedding must have shape (n, 2) and labels shape (n,), got {embedding.shape} "
            f"and {labels.shape}"
        )
    n_names = 0 if target_names is None else len(target_names)
    if labels.dtype.kind == "f" and np.array_equal(labels, np.round(labels)):
        labels = labels.astype(np.int64)  # 0.0, 1.0... as a classifier may return them
    if labels.size and (
        labels.dtype.kind not in "iu" or labels.min() < 0 or (n_names and labels.max() >= n_names)
    ):
        # -1 took the last name; text failed deep in NumPy.
        found = np.unique(labels)
        shown = ", ".join(map(repr, found[:5].tolist())) + (", ..." if len(found) > 5 else "")
        raise ValueError(
            "labels must be integers from 0"
            + (f" to {n_names - 1} (indices of target_names)" if n_names else "")
            + f", got {shown}"
        )
    ax = _axes(ax)
    classes = np.unique(labels)
    n_classes = int(max(classes.max() + 1, n_names)) if classes.size else 0
    styles = _class_styles(n_classes)
    for c in classes:
        name = target_names[c] if target_names is not None else str(c)
        points = embedding[labels == c]
        color, marker = styles[int(c)]
        ax.scatter(points[:, 0], points[:, 1], s=22, color=color, marker=marker, label=name)
    ax.legend(
        fontsize=7,
        markerscale=0.8,
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        borderaxespad=0.0,
        ncol=1 if len(classes) <= 20 else 2,
        frameon=False,
    )
    ax.set_xticks([])
    ax.set_yticks([])
    return ax


def plot_mesh_function(
    vertices, faces=None, values=None, ax=None, *, cmap="coolwarm", colorbar_label=None
):
    """Draw a function on a triangle mesh (face colour = mean of its vertex values), or
    on a point cloud (no faces: one dot per point).

    Parameters
    ----------
    vertices : ndarray of shape (n, 3), or a ScalarField
        With a ScalarField, ``faces`` and ``values`` (its first column) come from it.
    faces : ndarray of shape (m, 3)
        Empty (or None) for a point cloud.
    values : ndarray of shape (n,)
    ax : matplotlib 3-D Axes, optional
    cmap : str, default="coolwarm"
    colorbar_label : str, optional
        Label of the colour bar (with a ScalarField whose ``values`` are
        eigenfunctions, default: ``"eigenfunction value"``).

    Returns
    -------
    ax : matplotlib 3-D Axes
    """
    if hasattr(vertices, "values") and hasattr(vertices, "faces"):
        field = vertices
        vertices, faces = field.vertices, field.faces
        values = field.columns()[0]
        if colorbar_label is None and getattr(field, "eigenvalues", None) is not None:
            colorbar_label = "eigenfunction value"
    plt = pyplot()
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    ax = _axes(ax, projection="3d")
    vertices = np.asarray(vertices, dtype=float)
    faces = np.asarray(faces if faces is not None else np.empty((0, 3)), dtype=np.intp)
    values = np.asarray(values, dtype=float)
    if len(faces) == 0:  # a point cloud: one dot per point
        norm = plt.Normalize(values.min(), values.max())
        ax.scatter(*vertices.T, c=values, cmap=cmap, norm=norm, s=2, linewidths=0)
    else:
        face_values = values[faces].mean(axis=1)
        norm = plt.Normalize(face_values.min(), face_values.max())
        colors = plt.get_cmap(cmap)(norm(face_values))
        ax.add_collection3d(Poly3DCollection(vertices[faces], facecolors=colors, linewidths=0))
    center = (vertices.max(0) + vertices.min(0)) / 2
    radius = (vertices.max(0) - vertices.min(0)).max() / 2
    ax.set_xlim(center[0] - radius, center[0] + radius)
    ax.set_ylim(center[1] - radius, center[1] + radius)
    ax.set_zlim(center[2] - radius, center[2] + radius)
    ax.set_box_aspect((1, 1, 1))
    ax.set_axis_off()
    mappable = plt.cm.ScalarMappable(norm=norm, cmap=cmap)
    bar = ax.figure.colorbar(mappable, ax=ax, shrink=0.6)
    if colorbar_label:
        bar.set_label(colorbar_label, fontsize=8)
    return ax
