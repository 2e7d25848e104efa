"""Reading graph datasets in the TU text format (Morris et al., TUDataset, 2020).

A TU dataset ``DS`` is a folder of text files, numbers separated by commas, one record a
line, each file plain or compressed (``.gz``, ``.bz2``, ``.xz``):

- ``DS_A.txt``: ``i, j`` per directed edge; node ids are 1-based and count the nodes of
  all the graphs;
- ``DS_graph_indicator.txt``: line ``k`` holds the graph id (1-based) of node ``k``: the
  nodes of a graph are consecutive, graph ids start at 1 and have no gaps;
- ``DS_graph_labels.txt``: line ``g`` holds the class of graph ``g``;
- optional ``DS_node_labels.txt`` and ``DS_node_attributes.txt``: one line per node;
  their columns (labels first) become the graphs' ``node_values``.

Edge labels and attributes, graph attributes and the README are not read. Both
directions of an edge, repeated edges and self-loops are treated as by
:func:`sklearn_meshph.check_graph` (one edge of weight 1; loops dropped). Each file is
parsed whole with NumPy (no Python loop over its lines), never beyond
``MAX_TU_FILE_SIZE`` bytes once decompressed; nothing in a file is executed.
"""

from __future__ import annotations

import io
import os
import re
import warnings

import numpy as np

from ..mesh.reading import COMPRESSIONS, decompress, split_compression
from ..mesh.text import long_line_offset
from .validation import Graph

__all__ = [
    "MAX_TU_FILE_SIZE",
    "MAX_TU_GRAPHS",
    "MAX_TU_LINE",
    "load_tu_dataset",
    "tu_dataset_names",
]

#: Largest size of one file of a TU dataset, in bytes (512 MiB, as for point-cloud text),
#: decompressed. Loading peaks near 9 times the edge file's size for its shortest lines
#: ("1, 2": 16 bytes of pairs per 5 of text, and the text itself): 0.9 GB for 100 MB,
#: so about 4.5 GB for a file at the limit.
MAX_TU_FILE_SIZE = 512 * 1024**2
#: Most graphs of a TU dataset (a million: the largest of the collection has about
#: 200,000). A graph costs one short line of each of two files but about 600 bytes
#: loaded: 60 million one-node graphs fit in files at MAX_TU_FILE_SIZE, and 15 MB of
#: them compressed would have taken 36 GB.
MAX_TU_GRAPHS = 1_000_000

_ENDINGS = ("", *COMPRESSIONS)
_INT64 = np.iinfo(np.int64)
_NO_BAD_LINE = "its lines are not plain numbers"


def _find(folder: str, name: str, part: str) -> str | None:
    """The path of ``DS_part.txt`` in ``folder``, plain first, then compressed."""
    for ending in _ENDINGS:
        path = os.path.join(folder, f"{name}_{part}.txt{ending}")
        if os.path.isfile(path):
            return path
    return None


def tu_dataset_names(folder) -> list[str]:
    """The names ``DS`` of the TU datasets in ``folder`` (those with a ``DS_A.txt`` and
    a ``DS_graph_indicator.txt``, plain or compressed), sorted; empty for any other
    folder or a path that is not a folder."""
    folder = os.fsdecode(os.fspath(folder))
    if not os.path.isdir(folder):
        return []
    return sorted(n for n in _a_names(folder) if _find(folder, n, "graph_indicator") is not None)


def _a_names(folder: str) -> set[str]:
    """The names ``DS`` of the ``DS_A.txt`` files in ``folder`` (plain or compressed)."""
    pattern = re.compile(r"(.+)_A\.txt(" + "|".join(map(re.escape, COMPRESSIONS)) + r")?")
    return {m.group(1) for f in os.listdir(folder) if (m := pattern.fullmatch(f))}


def _irregular(folder: str, names) -> str | None:
    """The first file of a dataset of ``names`` that exists and is not a regular file
    (a FIFO, a folder), or None."""
    for name in sorted(names):
        for part in ("A", "graph_indicator", "graph_labels"):
            for ending in _ENDINGS:
                path = os.path.join(folder, f"{name}_{part}.txt{ending}")
                if os.path.lexists(path) and not os.path.isfile(path):
                    return path
    return None


def _content(path: str, place: str) -> bytes:
    _, compression = split_compression(path)
    if compression is not None:
        if os.path.getsize(path) == 0:  # Python reads an empty .gz or .bz2 as no data
            raise ValueError(f"{place}: TU file {path!r} is empty, not valid {compression} data")
        return _without_bom(
            decompress(path, compression, place, MAX_TU_FILE_SIZE, "TU file").getvalue()
        )
    if os.path.getsize(path) > MAX_TU_FILE_SIZE:
        raise ValueError(
            f"{place}: TU file {path!r} is larger than {MAX_TU_FILE_SIZE} bytes "
            "(the limit, MAX_TU_FILE_SIZE); refusing to read it"
        )
    with open(path, "rb") as stream:
        return _without_bom(stream.read())


def _without_bom(content: bytes) -> bytes:
    """``content`` without a leading UTF-8 byte order mark (what some editors write)."""
    return content[3:] if content.startswith(b"\xef\xbb\xbf") else content


_BLANK_LINES = re.compile(rb"(?m)^[ \t\f\v]*(?:\n|\Z)")
_MAX_WIDTH = 1 << 16  # values of one line looked at, on the error path
#: Longest line of a TU file, in bytes (1 MiB: tens of thousands of attributes).
MAX_TU_LINE = 1 << 20
_ERROR_CHUNK = 1 << 16  # bytes of text looked at a time (a Python object per line in it)
_NOT_SPACE = np.ones(256, dtype=bool)  # by byte value: not what a blank line holds
_NOT_SPACE[np.frombuffer(b" \t\n\x0b\x0c", np.uint8)] = False


def _newlines(content: bytes) -> bytes:
    """``content`` with every line end (``\r\n``, a lone ``\r``) made ``\n``: the
    same lines as ``bytes.splitlines``, one copy of the text."""
    if b"\r" not in content:
        return content
    # bytes.replace, not re.sub: a regular expression's substitution holds a Python
    # object per replaced line end (43 bytes of memory per byte of "1, 2\r" lines).
    return content.replace(b"\r\n", b"\n").replace(b"\r", b"\n")


def _without_blank_lines(content: bytes) -> bytes:
    """``content`` with line ends made ``\n`` and blank lines (or lines of spaces)
    left out, a piece at a time (a substitution holds a Python object per match)."""
    return b"".join(_BLANK_LINES.sub(b"", piece) for _, piece in _chunks(_newlines(content)))


def _chunks(content: bytes):
    """``(number of its first line, piece)`` of ``\n``-ended text, in pieces of about
    ``_ERROR_CHUNK`` bytes cut after a line end, so that the error paths hold neither a
    list of all the lines nor a Python object per line beyond one piece."""
    start, number, end = 0, 1, len(content)
    while start < end:
        stop = min(start + _ERROR_CHUNK, end)
        if stop < end:
            cut = content.rfind(b"\n", start, stop)
            cut = content.find(b"\n", stop) if cut < 0 else cut  # a line longer than that
            stop = end if cut < 0 else cut + 1
        piece = content[start:stop]
        yield number, piece
        number += piece.count(b"\n")
        start = stop


def _filled_lines(piece: bytes) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Indices in ``piece`` of its lines that are not blank, and every line's start and
    end offsets: a byte of memory per byte of text, and 8 per line (a piece is one line
    when that line is longer than ``_ERROR_CHUNK``)."""
    data = np.frombuffer(piece, np.uint8)
    ends = np.flatnonzero(data == 10)
    if not len(ends) or ends[-1] != len(data) - 1:
        ends = np.append(ends, len(data))
    starts = np.concatenate([[0], ends[:-1] + 1])
    filled = np.logical_or.reduceat(_NOT_SPACE[data], starts)
    return np.flatnonzero(filled), starts, ends


def _line_number(content: bytes, row: int) -> int:
    """The line number (1-based) of table row ``row`` (blank lines hold no row)."""
    for number, piece in _chunks(_newlines(content)):
        filled = _filled_lines(piece)[0]
        if row < len(filled):
            return number + int(filled[row])
        row -= len(filled)
    raise AssertionError("a table row beyond the file's lines")  # callers pass a row read


def _bad_line(content: bytes, dtype, width: int | None) -> str:
    """Where and why ``content`` is not a table of ``dtype`` (the error path only):
    NumPy reads it a piece at a time, and the first piece it cannot read line by line."""
    for number, piece in _chunks(_newlines(content)):
        table = _loaded(piece, dtype)
        if table is None:  # lines of spaces alone: NumPy refuses them
            table = _loaded(_without_blank_lines(piece), dtype)
        if table is not None and (table.size == 0 or width in (None, table.shape[1])):
            width = table.shape[1] if table.size else width
            continue
        filled, starts, ends = _filled_lines(piece)
        for index in filled:
            line = piece[starts[index] : ends[index]]
            reason, width = _bad_fields(line, number + int(index), dtype, width)
            if reason:
                return reason
    return _NO_BAD_LINE


def _bad_fields(line: bytes, number: int, dtype, width: int | None):
    """Why a line is not a row of ``width`` values of ``dtype`` (None if it is one),
    and the width."""
    count = line.count(b",") + 1  # counted first: a long line is not split into objects
    if width is None and count > _MAX_WIDTH:
        return f"line {number} holds {count} comma-separated values", width
    width = count if width is None else width
    if count != width:
        return (
            f"line {number} holds {count} comma-separated value(s) where {width} are expected"
        ), width
    fields = [f.strip() for f in line.decode("latin-1").split(",")]
    kind = "an integer" if dtype is np.int64 else "a number"
    for text in fields:
        if "_" in text:  # Python's int and float read "1_0" as 10; NumPy does not
            return f"line {number} holds {text[:40]!r}, not {kind}", width
        try:
            value = int(text) if dtype is np.int64 else float(text)
        except ValueError:
            return f"line {number} holds {text[:40]!r}, not {kind}", width
        if dtype is np.int64 and not _INT64.min <= value <= _INT64.max:
            return f"line {number} holds {value}, beyond 64-bit integers", width
    return None, width


def _loaded(content: bytes, dtype) -> np.ndarray | None:
    """``content`` parsed by NumPy as comma-separated rows, or None if it cannot be."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # an empty file: no rows
            return np.loadtxt(
                io.BytesIO(content), delimiter=",", dtype=dtype, ndmin=2, comments=None
            )
    except ValueError:
        return None


def _table(path: str, dtype, width: int | None, place: str) -> np.ndarray:
    """The numbers of a TU file as a 2-d array: a row per non-blank line, ``width``
    columns (any width, the same on every line, when None)."""
    content = _content(path, place)
    # NumPy's parser takes 13 to 20 bytes per byte of a long line (a 50 MB line of "1,"),
    # and TU lines hold a few numbers: refused before parsing.
    offset = long_line_offset(content, MAX_TU_LINE)
    if offset is not None:
        raise ValueError(
            f"{place}: cannot read TU file {path!r}: the line at byte {offset} is longer "
            f"than {MAX_TU_LINE} bytes (MAX_TU_LINE)"
        )
    table = _loaded(content, dtype)
    reason = None
    if table is None:
        reason = _bad_line(content, dtype, width)
        if reason == _NO_BAD_LINE:
            # Lines of spaces alone, or lines ended by a lone "\r": NumPy refuses what
            # the line rule (and _line_number) reads as blank lines; read without them.
            table = _loaded(_without_blank_lines(content), dtype)
    if table is not None and table.size == 0:
        table = np.empty((0, width or 1), dtype=dtype)
    if table is None or (width is not None and table.shape[1] != width):
        reason = reason or _bad_line(content, dtype, width)
        raise ValueError(f"{place}: cannot read TU file {path!r}: {reason}")
    if dtype is np.float64 and not np.isfinite(table).all():
        line = _line_number(content, int(np.flatnonzero(~np.isfinite(table).all(axis=1))[0]))
        raise ValueError(f"{place}: TU file {path!r}: line {line} holds a NaN or infinity")
    return table


def _row_error(place: str, path: str, row: int, problem: str):
    """The error of table row ``row`` of a file, naming its line (the file is read again:
    the error path only)."""
    line = _line_number(_content(path, place), row)
    return ValueError(f"{place}: TU file {path!r}: line {line}: {problem}")


def _graph_ids(path: str, place: str) -> np.ndarray:
    """The 1-based graph id of each node, checked: from 1, steps of 0 or 1."""
    ids = _table(path, np.int64, 1, place)[:, 0]
    if not len(ids):
        raise ValueError(f"{place}: TU file {path!r} holds no nodes")
    if ids[0] != 1:
        raise _row_error(place, path, 0, f"the first graph id is {ids[0]}, expected 1")
    steps = np.diff(ids)
    bad = np.flatnonzero((steps < 0) | (steps > 1))
    if len(bad):
        k = int(bad[0]) + 1
        raise _row_error(
            place,
            path,
            k,
            f"graph id {ids[k]} follows {ids[k - 1]}: graph ids must not decrease nor skip "
            "(the nodes of a graph on consecutive lines, graphs numbered 1, 2, ...)",
        )
    return ids


def _node_values(folder: str, name: str, n_nodes: int, place: str):
    """The node labels and attributes as columns (labels first), or None."""
    columns = []
    for part, dtype in (("node_labels", np.int64), ("node_attributes", np.float64)):
        path = _find(folder, name, part)
        if path is None:
            # Optional, but a FIFO or a folder under its name is not its absence.
            for ending in _ENDINGS:
                other = os.path.join(folder, f"{name}_{part}.txt{ending}")
                if os.path.lexists(other):
                    raise ValueError(f"{place}: TU file {other!r} is not a regular file")
            continue
        table = _table(path, dtype, None, place)
        if len(table) != n_nodes:
            raise ValueError(
                f"{place}: TU file {path!r} holds {len(table)} lines for {n_nodes} nodes"
            )
        columns.append(table.astype(np.float64))
    return np.hstack(columns) if columns else None


def _edges(path: str, ids: np.ndarray, place: str):
    """The edges as sorted unique 0-based ``(low, high)`` node pairs, checked: node ids
    in range, both ends in one graph; self-loops dropped."""
    pairs = _table(path, np.int64, 2, place)
    n_nodes = len(ids)
    # In place and a column at a time where it can be: the table is the largest thing
    # loaded (a file at MAX_TU_FILE_SIZE of short lines is about 1.7 GB of pairs).
    if pairs.size and (pairs.min() < 1 or pairs.max() > n_nodes):
        outside = (pairs < 1) | (pairs > n_nodes)
        row = int(np.flatnonzero(outside.any(axis=1))[0])
        value = pairs[row][outside[row]][0]
        raise _row_error(place, path, row, f"node id {value} is outside 1..{n_nodes}")
    pairs -= 1
    across = ids[pairs[:, 0]] != ids[pairs[:, 1]]
    if across.any():
        row = int(np.flatnonzero(across)[0])
        i, j = pairs[row] + 1
        raise _row_error(
            place,
            path,
            row,
            f"edge ({i}, {j}) joins graph {ids[i - 1]} and graph {ids[j - 1]}",
        )
    del across
    low, high = pairs.min(axis=1), pairs.max(axis=1)
    del pairs
    keys = low * n_nodes
    keys += high
    keys = keys[low != high]
    del low, high
    keys.sort()
    keys = keys[np.r_[True, keys[1:] != keys[:-1]]] if len(keys) else keys
    return keys // n_nodes, keys % n_nodes


def load_tu_dataset(folder, name: str | None = None) -> tuple[list[Graph], np.ndarray]:
    """The graphs and labels of a TU dataset folder.

    Parameters
    ----------
    folder : str or os.PathLike
        A folder holding ``DS_A.txt``, ``DS_graph_indicator.txt`` and
        ``DS_graph_labels.txt`` (each plain or compressed; the plain one when both are
        there), optionally
        ``DS_node_labels.txt`` and ``DS_node_attributes.txt``.
    name : str, optional
        The dataset's name ``DS``; by default the one dataset of the folder. A name,
        not a path: files outside ``folder`` are never read.

    Returns
    -------
    graphs : list of Graph
        Graph ``g`` (0-based) is graph ``g + 1`` of the files: its nodes in file order,
        its edges of weight 1, ``node_values`` the node labels then the node attributes
        (None when the folder has neither).
    y : ndarray of shape (n_graphs,), int64
        The graph labels as written in the file.

    Raises
    ------
    ValueError
        When ``folder`` holds no TU dataset (or several, and ``name`` is not given), a
        file is missing (or not a regular file), larger than ``MAX_TU_FILE_SIZE`` or not
        valid compressed data, the dataset has more than ``MAX_TU_GRAPHS`` graphs,
        a line is not integers (numbers for attributes) or has the wrong count, a node
        id is out of range, an edge joins two graphs, graph ids decrease or skip, or a
        file's line count does not match the nodes or graphs. The message names the
        file (and the line).
    """
    folder = os.fsdecode(os.fspath(folder))
    if not os.path.isdir(folder):
        raise ValueError(f"TU dataset folder {folder!r} does not exist or is not a folder")
    if name is None:
        names = tu_dataset_names(folder)
        irregular = None if names else _irregular(folder, _a_names(folder))
        if irregular is not None:
            raise ValueError(f"TU file {irregular!r} is not a regular file")
        if len(names) != 1:
            found = f"datasets {', '.join(names)}; pass name=" if names else "no TU dataset"
            raise ValueError(
                f"TU dataset folder {folder!r} holds {found} (a TU dataset DS is the files "
                "DS_A.txt, DS_graph_indicator.txt and DS_graph_labels.txt, plain or .gz)"
            )
        name = names[0]
    elif not isinstance(name, str) or name in ("", ".", "..") or os.path.basename(name) != name:
        # A name is a prefix of files in the folder, not a path to files elsewhere.
        raise ValueError(
            f"name must be the name of a TU dataset in {folder!r} (the DS of its DS_A.txt), "
            f"not a path; got {name!r}"
        )
    place = f"TU dataset {name}"
    paths = {}
    for part in ("A", "graph_indicator", "graph_labels"):
        paths[part] = _find(folder, name, part)
        if paths[part] is None:
            expected = os.path.join(folder, f"{name}_{part}.txt")
            raise ValueError(
                f"{place}: TU file {expected!r} (or .gz) does not exist or is not a regular file"
            )
    ids = _graph_ids(paths["graph_indicator"], place)
    n_graphs = int(ids[-1])
    if n_graphs > MAX_TU_GRAPHS:
        raise ValueError(
            f"{place}: TU file {paths['graph_indicator']!r} holds {n_graphs} graphs, more "
            f"than {MAX_TU_GRAPHS} (the limit, MAX_TU_GRAPHS); refusing to load them"
        )
    y = _table(paths["graph_labels"], np.int64, 1, place)[:, 0]
    if len(y) != n_graphs:
        raise ValueError(
            f"{place}: TU file {paths['graph_labels']!r} holds {len(y)} labels for "
            f"{n_graphs} graphs (in {paths['graph_indicator']!r})"
        )
    low, high = _edges(paths["A"], ids, place)
    values = _node_values(folder, name, len(ids), place)
    starts = np.r_[0, np.flatnonzero(np.diff(ids)) + 1, len(ids)]
    bounds = np.searchsorted(low, starts)
    local = np.column_stack([low, high]) - starts[ids[low] - 1][:, None]
    graphs = []
    for g in range(n_graphs):
        first, last, edges = starts[g], starts[g + 1], local[bounds[g] : bounds[g + 1]]
        nodes = None if values is None else values[first:last]
        graphs.append(Graph(int(last - first), edges, np.ones(len(edges)), nodes))
    return graphs, y
