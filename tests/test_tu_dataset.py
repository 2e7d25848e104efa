"""TU datasets: the text format read into graphs and labels, every bad file named; the
six shared datasets as their README describes them."""

import csv
import gzip
import json
import os
import re

import numpy as np
import pytest
from conftest import data_folder

from sklearn_meshph import Graph, _cli_args, cli, load_tu_dataset
from sklearn_meshph.cli import main
from sklearn_meshph.graph import reading, tu_dataset_names
from sklearn_meshph.pipelines import PRESETS

# Three graphs: a path 1-2-3 (both directions, a repeat), an edge 4-5 with a loop on 4,
# and node 6 alone. Labels as the file writes them (-1 and 1).
TINY = {
    "A": "1, 2\n2, 1\n2, 3\n3, 2\n2, 3\n4, 4\n5, 4\n4, 5\n",
    "graph_indicator": "1\n1\n1\n2\n2\n3\n",
    "graph_labels": "-1\n1\n1\n",
    "node_labels": "0\n1\n0\n2\n2\n1\n",
}


def write_tu(folder, files, name="TINY", compress=False):
    folder.mkdir(parents=True, exist_ok=True)
    for part, text in files.items():
        path = folder / f"{name}_{part}.txt"
        if compress:
            with gzip.open(f"{path}.gz", "wt") as stream:
                stream.write(text)
        else:
            path.write_text(text)
    return folder


def _check_tiny(graphs, y):
    assert len(graphs) == 3 and all(isinstance(g, Graph) for g in graphs)
    assert y.dtype == np.int64 and y.tolist() == [-1, 1, 1]
    assert [g.n_nodes for g in graphs] == [3, 2, 1]
    assert [g.edges.tolist() for g in graphs] == [[[0, 1], [1, 2]], [[0, 1]], []]
    assert all((g.weights == 1).all() for g in graphs)
    assert [g.node_values.ravel().tolist() for g in graphs] == [[0, 1, 0], [2, 2], [1]]


@pytest.mark.parametrize("compress", [False, True])
def test_a_tiny_dataset_gives_its_graphs_and_labels(tmp_path, compress):
    folder = write_tu(tmp_path / "tiny", TINY, compress=compress)
    _check_tiny(*load_tu_dataset(folder))
    assert tu_dataset_names(folder) == ["TINY"]


def test_plain_and_compressed_files_mix_and_attributes_follow_labels(tmp_path):
    folder = write_tu(tmp_path, {k: TINY[k] for k in ("A", "graph_indicator")})
    write_tu(tmp_path, {k: TINY[k] for k in ("graph_labels", "node_labels")}, compress=True)
    attributes = "0.5, 1\n1.5, 2\n2.5, 3\n3.5, 4\n4.5, 5\n5.5, 6\n"
    write_tu(tmp_path, {"node_attributes": attributes, "edge_labels": "x\n"})
    graphs, y = load_tu_dataset(str(folder))
    assert y.tolist() == [-1, 1, 1]
    np.testing.assert_array_equal(graphs[1].node_values, [[2, 3.5, 4], [2, 4.5, 5]])
    assert graphs[2].node_values.shape == (1, 3)


def test_without_node_files_graphs_have_no_node_values(tmp_path):
    folder = write_tu(tmp_path, {k: v for k, v in TINY.items() if k != "node_labels"})
    graphs, _ = load_tu_dataset(folder)
    assert all(g.node_values is None for g in graphs)


def test_the_dataset_is_named_when_a_folder_holds_several(tmp_path):
    write_tu(tmp_path, TINY)
    write_tu(tmp_path, {**TINY, "graph_labels": "5\n6\n7\n"}, name="OTHER")
    assert tu_dataset_names(tmp_path) == ["OTHER", "TINY"]
    with pytest.raises(ValueError, match="holds datasets OTHER, TINY; pass name="):
        load_tu_dataset(tmp_path)
    assert load_tu_dataset(tmp_path, name="OTHER")[1].tolist() == [5, 6, 7]
    _check_tiny(*load_tu_dataset(tmp_path, name="TINY"))
    # Found probing stop 52's surfaces: a name with a path in it read the files of a
    # dataset outside the folder.
    (tmp_path / "inner").mkdir()
    for name in ("../TINY", "inner/../TINY", "..", "", 5):
        with pytest.raises(ValueError, match="name must be the name of a TU dataset in"):
            load_tu_dataset(tmp_path / "inner", name=name)


def test_other_folders_are_not_tu_datasets(tmp_path):
    write_tu(tmp_path / "a", {"A": TINY["A"]})  # no graph indicator
    (tmp_path / "b").mkdir()
    (tmp_path / "b" / "notes_A.txt.zip").write_text("1, 2\n")
    for folder in (tmp_path / "a", tmp_path / "b", tmp_path / "missing"):
        assert tu_dataset_names(folder) == []
    with pytest.raises(ValueError, match="holds no TU dataset"):
        load_tu_dataset(tmp_path / "a")
    with pytest.raises(ValueError, match="does not exist or is not a folder"):
        load_tu_dataset(tmp_path / "missing")


def test_a_fifo_or_a_folder_in_place_of_a_tu_file_is_named_and_never_read(tmp_path):
    write_tu(tmp_path, {part: text for part, text in TINY.items() if part != "graph_labels"})
    os.mkfifo(tmp_path / "TINY_graph_labels.txt")  # reading it would block forever
    with pytest.raises(ValueError, match=r"TINY_graph_labels.txt' .*is not a regular file"):
        load_tu_dataset(tmp_path)
    os.unlink(tmp_path / "TINY_graph_labels.txt")
    (tmp_path / "TINY_graph_labels.txt").mkdir()
    with pytest.raises(ValueError, match=r"TINY_graph_labels.txt' .*is not a regular file"):
        load_tu_dataset(tmp_path)
    # The optional files too: a FIFO under their name is not their absence.
    (tmp_path / "TINY_graph_labels.txt").rmdir()
    write_tu(tmp_path, {"graph_labels": TINY["graph_labels"]})
    os.mkfifo(tmp_path / "TINY_node_attributes.txt.gz")
    with pytest.raises(ValueError, match=r"node_attributes.txt.gz' is not a regular file"):
        load_tu_dataset(tmp_path)
    # Found by an adversarial review: a FIFO as the graph indicator, the file that
    # names a dataset, made the folder "hold no TU dataset".
    os.unlink(tmp_path / "TINY_node_attributes.txt.gz")
    os.unlink(tmp_path / "TINY_graph_indicator.txt")
    os.mkfifo(tmp_path / "TINY_graph_indicator.txt")
    with pytest.raises(ValueError, match=r"graph_indicator.txt' is not a regular file"):
        load_tu_dataset(tmp_path)


def test_more_graphs_than_the_limit_are_refused_before_they_are_built(tmp_path, monkeypatch):
    folder = write_tu(tmp_path, TINY)
    monkeypatch.setattr(reading, "MAX_TU_GRAPHS", 2)
    with pytest.raises(ValueError, match=r"graph_indicator.txt' holds 3 graphs, more than 2"):
        load_tu_dataset(folder)


def test_a_byte_order_mark_bytes_paths_and_decompression_errors(tmp_path):
    folder = write_tu(tmp_path / "bom", TINY)
    for part in ("A", "graph_labels"):
        path = folder / f"TINY_{part}.txt"
        path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    _check_tiny(*load_tu_dataset(os.fsencode(folder)))
    assert tu_dataset_names(os.fsencode(folder)) == ["TINY"]
    (folder / "TINY_A.txt").unlink()
    (folder / "TINY_A.txt.gz").write_bytes(b"not gzip at all")
    with pytest.raises(ValueError, match=r"not valid .gz data, so not a valid TU file$"):
        load_tu_dataset(folder)


BAD_FILES = [
    ({"graph_labels": None}, r"TINY_graph_labels.txt' \(or .gz\) does not exist"),
    ({"A": "1, 2\n2, x\n"}, r"TINY_A.txt': line 2 holds 'x', not an integer"),
    (
        {"A": "1, 2\n\n2, 3, 1\n"},
        r"TINY_A.txt': line 3 holds 3 comma-separated value\(s\) where 2",
    ),
    ({"A": "1.0, 2.0\n"}, r"TINY_A.txt': line 1 holds '1.0', not an integer"),
    ({"A": "1, 2\n1_0, 2\n"}, r"TINY_A.txt': line 2 holds '1_0', not an integer"),
    ({"A": "1, 2\n \n7, 1\n"}, r"TINY_A.txt': line 3: node id 7 is outside 1..6"),
    ({"A": "1, 2\n2 3\n"}, r"line 2 holds 1 comma-separated value\(s\) where 2"),
    ({"A": "1\n"}, r"TINY_A.txt': line 1 holds 1 comma-separated value\(s\) where 2"),
    ({"A": "1, 2\n" * 3 + "\n7, 6\n"}, r"TINY_A.txt': line 5: node id 7 is outside 1..6"),
    ({"A": "0, 1\n"}, r"TINY_A.txt': line 1: node id 0 is outside 1..6"),
    ({"A": "99999999999999999999, 1\n"}, "line 1 holds 99999999999999999999, beyond 64-bit"),
    ({"A": "1, 2\n3, 4\n"}, r"TINY_A.txt': line 2: edge \(3, 4\) joins graph 1 and graph 2"),
    ({"graph_indicator": "1\n1\n2\n\n1\n2\n3\n"}, "line 5: graph id 1 follows 2: graph ids must"),
    ({"graph_indicator": "1\n1\n1\n2\n2\n4\n"}, "line 6: graph id 4 follows 2: graph ids must"),
    ({"graph_indicator": "2\n2\n2\n3\n3\n4\n"}, "line 1: the first graph id is 2, expected 1"),
    ({"graph_indicator": ""}, "TINY_graph_indicator.txt' holds no nodes"),
    ({"graph_labels": "1\n1\n"}, r"graph_labels.txt' holds 2 labels for 3 graphs \(in .*"),
    ({"graph_labels": "1\n1\n1\n1\n"}, "graph_labels.txt' holds 4 labels for 3 graphs"),
    ({"graph_labels": "1\nA\n1\n"}, "graph_labels.txt': line 2 holds 'A', not an integer"),
    ({"node_labels": "0\n1\n"}, "node_labels.txt' holds 2 lines for 6 nodes"),
    ({"node_attributes": "1\n\n2\n3\n4\nnan\n6\n"}, "attributes.txt': line 6 holds a NaN"),
    ({"node_attributes": "1\n2\n3\n4\n5\nsix\n"}, "line 6 holds 'six', not a number"),
    (
        {"node_attributes": "1, 2\n2\n3\n4\n5\n6\n"},
        "line 2 holds 1 comma-separated value\\(s\\) where 2",
    ),
]


@pytest.mark.parametrize("change, message", BAD_FILES)
def test_a_bad_file_is_named_with_its_line(tmp_path, change, message):
    files = {k: v for k, v in {**TINY, **change}.items() if v is not None}
    folder = write_tu(tmp_path, files)
    with pytest.raises(ValueError, match=f"^TU dataset TINY: .*{message}"):
        load_tu_dataset(folder)


def test_lines_of_spaces_and_lone_carriage_returns_are_read_as_the_line_rule_says(tmp_path):
    """Blank lines hold no row, whatever their spaces; a lone "\\r" ends a line."""
    spaced = TINY["A"].replace("2, 3\n", "2, 3\n \t \n", 1)
    _check_tiny(*load_tu_dataset(write_tu(tmp_path / "spaces", {**TINY, "A": spaced})))
    returns = {**TINY, "A": TINY["A"].replace("\n", "\r")}
    _check_tiny(*load_tu_dataset(write_tu(tmp_path / "returns", returns)))


@pytest.mark.parametrize("ending", [".gz", ".bz2"])
def test_an_empty_compressed_file_is_refused_not_read_as_no_edges(tmp_path, ending):
    """Python reads an empty .gz or .bz2 as no data: a failed download would have been
    a dataset of graphs without edges."""
    folder = write_tu(tmp_path, TINY)
    (folder / "TINY_A.txt").unlink()
    (folder / f"TINY_A.txt{ending}").write_bytes(b"")
    with pytest.raises(ValueError, match=r"TINY_A.txt.*' is empty, not valid"):
        load_tu_dataset(folder)


def test_a_corrupt_compressed_file_is_named(tmp_path):
    folder = write_tu(tmp_path, TINY)
    (folder / "TINY_A.txt").unlink()
    (folder / "TINY_A.txt.gz").write_bytes(b"not gzip at all")
    with pytest.raises(ValueError, match=r"cannot decompress TU file .*TINY_A.txt.gz"):
        load_tu_dataset(folder)


@pytest.mark.parametrize("compress", [False, True])
def test_files_beyond_the_size_limit_are_refused(tmp_path, monkeypatch, compress):
    folder = write_tu(tmp_path, TINY, compress=compress)
    monkeypatch.setattr(reading, "MAX_TU_FILE_SIZE", 20)
    with pytest.raises(ValueError, match=r"TINY_A.txt(.gz)?'.* than 20 bytes"):
        load_tu_dataset(folder)


# The shared datasets (skipped without them) -------------------------------------

# From /work/shared/data/tu/README.md: graphs, class counts, mean nodes, mean edges.
README_TABLE = {
    "MUTAG": (188, [63, 125], 17.9, 19.8),
    "COX2": (467, [365, 102], 41.2, 43.4),
    "DHFR": (756, [295, 461], 42.4, 44.5),
    "PROTEINS": (1113, [663, 450], 39.1, 72.8),
    "NCI1": (4110, [2053, 2057], 29.9, 32.3),
    "IMDB-BINARY": (1000, [500, 500], 19.8, 96.5),
}


@pytest.mark.parametrize("name", README_TABLE)
def test_the_shared_datasets_match_their_readme(name):
    folder = data_folder(f"tu/{name}", "TU")
    graphs, y = load_tu_dataset(folder)
    n_graphs, counts, mean_nodes, mean_edges = README_TABLE[name]
    assert len(graphs) == len(y) == n_graphs
    assert np.unique(y, return_counts=True)[1].tolist() == counts
    assert round(np.mean([g.n_nodes for g in graphs]), 1) == mean_nodes
    assert round(np.mean([g.n_edges for g in graphs]), 1) == mean_edges


# The main job on a TU folder -----------------------------------------------------

FAST = ["--verbose", "0", "--n-jobs", "1", "--folds", "2"]


def _toy(n_graphs=16):
    """Cycles (label 1) and paths (label 2) of 5 to 12 nodes, as TU files."""
    edges, ids, labels, start = [], [], [], 1
    for g in range(n_graphs):
        n, label = 5 + g % 8, 1 + g % 2
        pairs = [(start + k, start + k + 1) for k in range(n - 1)]
        pairs += [(start, start + n - 1)] if label == 1 else []
        edges += [f"{i}, {j}\n{j}, {i}\n" for i, j in pairs]
        ids += [f"{g + 1}\n"] * n
        labels.append(f"{label}\n")
        start += n
    return {"A": "".join(edges), "graph_indicator": "".join(ids), "graph_labels": "".join(labels)}


@pytest.fixture
def graph_preset(monkeypatch):
    """The main job's preset for graphs: "graph", or while PRESETS has none, a stand-in
    whose Laplacian graphs take ("paper")."""
    if _cli_args.GRAPH_PRESET not in PRESETS:
        monkeypatch.setattr(_cli_args, "GRAPH_PRESET", "paper")
    return _cli_args.GRAPH_PRESET


def _error_line(capfd) -> str:
    captured = capfd.readouterr()
    lines = [line for line in captured.err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), captured.err
    assert "Traceback" not in captured.err + captured.out
    return lines[0]


def test_the_main_job_classifies_a_tu_folder(tmp_path, capsys, graph_preset):
    folder = write_tu(tmp_path / "TOY", _toy(), name="TOY", compress=True)
    out = tmp_path / "out"
    assert main([str(folder), *FAST, "--output", str(out)]) == 0
    printed = capsys.readouterr().out
    assert f"data: TU dataset TOY ({folder}): 16 graphs, 2 classes" in printed
    assert f"preset {graph_preset!r}" in printed
    assert "pictures in" in printed and not (out / "eigenfunctions.png").exists()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["preset"] == graph_preset and summary["n_samples"] == 16
    assert summary["class_names"] == ["1", "2"] and summary["class_counts"] == [8, 8]
    with open(out / "predictions.csv") as stream:
        rows = list(csv.DictReader(stream))
    assert [row["file"] for row in rows[:3]] == ["graph 1", "graph 2", "graph 3"]
    assert [row["true label"] for row in rows[:3]] == ["1", "2", "1"]


@pytest.mark.parametrize(
    "options",
    [
        ["--laplacian", "cotangent"],
        ["--set", "eigen__laplacian=cotangent"],
        ["--preset", "default"],
    ],
)
def test_a_surface_laplacian_on_graphs_is_one_line_before_loading(
    tmp_path, capfd, monkeypatch, graph_preset, options
):
    monkeypatch.setattr(cli, "load_tu_dataset", None)  # loading would fail the test
    folder = write_tu(tmp_path / "TOY", _toy(), name="TOY")
    assert main([str(folder), *FAST, "--no-plots", "--output", str(tmp_path), *options]) == 2
    assert "Laplacian 'cotangent' is a surface's" in _error_line(capfd)


def test_bad_tu_folders_are_one_line_in_the_main_job(tmp_path, capfd, graph_preset):
    argv = [*FAST, "--no-plots", "--output", str(tmp_path / "out")]
    broken = write_tu(tmp_path / "broken", {**_toy(), "A": "1, 2\n2, x\n"}, name="TOY")
    assert main([str(broken), *argv]) == 1
    assert re.search(r"TOY_A.txt': line 2 holds 'x', not an integer$", _error_line(capfd))
    two = write_tu(tmp_path / "two", _toy(), name="TOY")
    write_tu(two, _toy(), name="OTHER")
    assert main([str(two), *argv]) == 2
    assert "holds several TU datasets (OTHER, TOY); give the folder of one" in _error_line(capfd)
    assert main([str(write_tu(tmp_path / "few", _toy(6), name="TOY")), *argv, "--folds", "4"]) == 2
    assert "fewer samples than --folds 4" in _error_line(capfd)
    # one label: the classes are the labels' values, not sub-folders
    one = {**_toy(), "graph_labels": "1\n" * 16}
    assert main([str(write_tu(tmp_path / "one", one, name="TOY")), *argv]) == 2
    assert "give a TU dataset whose graph labels take at least two" in _error_line(capfd)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (b"\n" * 2_000_000 + b"1, x\n", r"line 2000001 holds 'x', not an integer"),
        (b"1, 2\r" * 400_000 + b"1, 2, 3\r", r"line 400001 holds 3 comma-separated value"),
        (b"1, 2\n" * 200_000 + b" \r" * 400_000 + b"1,\n", r"line 600001 holds '', not an"),
        (b" \n" * 1_000_000 + b"1, 2\n" + b"1, 2.5\n", r"line 1000002 holds '2.5', not an"),
    ],
)
def test_naming_the_bad_line_of_a_large_file_holds_no_list_of_its_lines(tmp_path, content, message):
    """A list of every line (and a regular expression's substitution over them all)
    took 17 to 43 bytes of memory per byte of file: a 505 KB gzip peaked at 8.9 GB."""
    import tracemalloc

    path = tmp_path / "DS_A.txt.gz"
    path.write_bytes(gzip.compress(content))
    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match=message):
            reading._table(str(path), np.int64, 2, "dataset")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 8 * len(content) + 64 * 2**20


@pytest.mark.parametrize("line", [b"1" * 50_000_000, b"1," * 25_000_000])
def test_a_line_longer_than_any_tu_line_is_refused_before_parsing(tmp_path, line):
    """Found by an adversarial review: NumPy's parser, and the error path after it, took
    13 to 20 bytes per byte of one long line (a 194 KB gzip reached a MemoryError)."""
    import tracemalloc

    content = b"1, 2\n" + line + b"\n"
    path = tmp_path / "DS_A.txt.gz"
    path.write_bytes(gzip.compress(content))
    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match=r"the line at byte 5 is longer than 1048576 bytes"):
            reading._table(str(path), np.int64, 2, "dataset")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 3 * len(content)
