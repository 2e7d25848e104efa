"""PerDiagramDistance's cache of stacks is data only: one ``.npy`` file per stack, read
only from a regular file of the expected dtype and shape, never unpickled nor blocked
on; a tampered entry is recomputed (and replaced) with a CacheWarning."""

import os
import pickle

import joblib
import numpy as np
import pytest
from conftest import nest_folders, remove_nested

from sklearn_meshph import PerDiagramDistance
from sklearn_meshph.diagrams import pairwise, per_diagram
from sklearn_meshph.spectral.cache import CacheWarning

UNPICKLED = []


def _mark():
    UNPICKLED.append(True)


class Hostile:
    """Runs ``_mark`` when unpickled."""

    def __reduce__(self):
        return (_mark, ())


def samples(n=5, seed=0):
    rng = np.random.default_rng(seed)
    result = []
    for _ in range(n):
        births = rng.random((2, 4))
        result.append(tuple(np.column_stack([b, b + rng.random(4)]) for b in births))
    return result


@pytest.fixture
def calls(monkeypatch):
    """The stacks computed (each a distance matrix per diagram position)."""
    counted = []

    def counting(*args, **kwargs):
        counted.append(len(args[0]))
        return pairwise.distance_stack(*args, **kwargs)

    monkeypatch.setattr(per_diagram, "distance_stack", counting)
    return counted


def entries(location):
    return sorted((location / "sklearn_meshph_distances").iterdir())


def test_a_stack_is_one_npy_file_and_read_again_without_computing(tmp_path, calls):
    X, Y = samples(), samples(3, seed=1)
    fresh = PerDiagramDistance(metric="bottleneck").fit(X)
    expected, cross = fresh.fit_transform(X), fresh.transform(Y)
    calls.clear()
    stage = PerDiagramDistance(metric="bottleneck", memory=joblib.Memory(tmp_path, verbose=0))
    assert np.array_equal(stage.fit_transform(X), expected)
    assert np.array_equal(stage.transform(Y), cross)
    assert len(calls) == 2
    stored = entries(tmp_path)
    assert [path.suffix for path in stored] == [".npy", ".npy"]
    assert not list(tmp_path.rglob("*.pkl"))  # no pickle, no temporary file left
    loaded = [np.load(path, allow_pickle=False) for path in stored]
    assert sorted(a.shape for a in loaded) == [(3, 5, 2), (5, 5, 2)]
    calls.clear()
    again = PerDiagramDistance(metric="bottleneck", memory=str(tmp_path))
    assert np.array_equal(again.fit_transform(X), expected)
    assert np.array_equal(again.transform(Y), cross)
    assert calls == []
    # Another parameter, another entry; a joblib.Memory without location, no cache.
    PerDiagramDistance(metric="bottleneck", internal_p=1.0, memory=tmp_path).fit_transform(X)
    assert len(entries(tmp_path)) == 3
    none = PerDiagramDistance(memory=joblib.Memory(None, verbose=0)).fit_transform(X)
    assert none.shape == (5, 5, 2) and len(entries(tmp_path)) == 3


def _pickle(path):
    np.save(path, np.array([Hostile(), 1.0], dtype=object), allow_pickle=True)


def _truncated(path):  # cut in the data, before the digest that ends the file
    data = path.read_bytes()
    path.write_bytes(data[: len(data) - 40])


def _flipped(path):  # one bit of the data: well-formed, finite, positive
    data = bytearray(path.read_bytes())
    data[-40] ^= 1
    path.write_bytes(bytes(data))


def _without_digest(path):  # the same stack, as the format before the digests
    np.save(path, np.load(path, allow_pickle=False))


def _other_entry(path):  # another stack of the same shape, digest and all
    location = path.parent.parent
    other = PerDiagramDistance(memory=location)
    other.fit_transform(samples(seed=9))
    (newer,) = [p for p in entries(location) if p != path]
    os.replace(newer, path)


def _wrong_shape(path):
    np.save(path, np.zeros((5, 4, 2)))


def _negative(path):
    np.save(path, -np.ones((5, 5, 2)))


def _fifo(path):
    path.unlink()
    os.mkfifo(path)


def _folder(path):
    path.unlink()
    path.mkdir()
    (path / "inside.npy").write_bytes(b"")


def _link(path):
    elsewhere = path.parent.parent / "elsewhere.npy"
    os.replace(path, elsewhere)
    path.symlink_to(elsewhere)


@pytest.mark.parametrize(
    "tamper",
    [
        _pickle,
        _truncated,
        _flipped,
        _without_digest,
        _other_entry,
        _wrong_shape,
        _negative,
        _fifo,
        _folder,
        _link,
    ],
)
def test_a_tampered_entry_is_recomputed_with_a_warning(tmp_path, calls, tamper):
    if tamper is _fifo and not hasattr(os, "mkfifo"):
        pytest.skip("no FIFOs here")
    X = samples()
    expected = PerDiagramDistance().fit_transform(X)
    stage = PerDiagramDistance(memory=tmp_path)
    stage.fit_transform(X)
    (entry,) = entries(tmp_path)
    tamper(entry)
    calls.clear()
    UNPICKLED.clear()
    with pytest.warns(CacheWarning, match="distance cache entry .* is unusable"):
        assert np.array_equal(stage.fit_transform(X), expected)
    assert UNPICKLED == [] and len(calls) == 1
    # Replaced by a good entry: read without computing nor warning.
    assert entry.is_file() and not entry.is_symlink()
    calls.clear()
    assert np.array_equal(stage.fit_transform(X), expected)
    assert calls == []


def test_the_pickle_of_the_hostile_object_would_run():
    UNPICKLED.clear()
    pickle.loads(pickle.dumps(Hostile()))
    assert UNPICKLED == [True]


@pytest.mark.parametrize("kind", ["file", "fifo"])
def test_a_memory_path_that_is_not_a_folder_is_refused(tmp_path, kind):
    if kind == "fifo" and not hasattr(os, "mkfifo"):
        pytest.skip("no FIFOs here")
    path = tmp_path / "memory"
    path.write_bytes(b"") if kind == "file" else os.mkfifo(path)
    with pytest.raises(ValueError, match="memory must be a folder.*'.*memory' is not a folder"):
        PerDiagramDistance(memory=path).fit_transform(samples())
    with pytest.raises(ValueError, match="memory must be a folder.*an empty path"):
        PerDiagramDistance(memory="").fit_transform(samples())


def test_a_caching_object_of_the_users_is_used_as_before(tmp_path):
    cached = []

    class Recorder:
        def cache(self, function, ignore=None):
            def call(*args, **kwargs):
                cached.append(args[0])
                return function(*args, **kwargs)

            return call

    X = samples()
    result = PerDiagramDistance(memory=Recorder()).fit_transform(X)
    assert np.array_equal(result, PerDiagramDistance().fit_transform(X))
    assert len(cached) == 1


def test_temporary_files_of_killed_writers_are_swept(tmp_path):
    folder = tmp_path / "sklearn_meshph_distances"
    folder.mkdir()
    old = 10 * 3600
    orphans = [folder / ".dead.1.a.tmp", folder / ".dead.2.b.tmp"]
    orphans[0].write_bytes(b"half a stack")
    os.mkfifo(orphans[1])  # a strange file: removed, never opened
    fresh = folder / ".busy.3.c.tmp"  # a writer at work right now: kept
    fresh.write_bytes(b"being written")
    target = tmp_path / "kept.txt"
    target.write_text("not in the cache")
    link = folder / ".link.4.d.tmp"
    link.symlink_to(target)
    for path in [*orphans, link]:
        os.utime(
            path, (path.lstat().st_atime - old, path.lstat().st_mtime - old), follow_symlinks=False
        )
    PerDiagramDistance(metric="bottleneck", memory=tmp_path).fit_transform(samples())
    assert not any(path.exists() or path.is_symlink() for path in [*orphans, link])
    assert fresh.exists() and target.read_text() == "not in the cache"
    assert [path.suffix for path in entries(tmp_path)] == [".tmp", ".npy"] or len(
        entries(tmp_path)
    ) == 2


@pytest.mark.skipif(os.name != "posix", reason="needs POSIX")
def test_an_entry_that_is_a_deep_folder_is_neither_followed_nor_a_recursion(tmp_path, calls):
    """A folder nested thousands of levels deep in an entry's place raised RecursionError
    from the removal before the store; it is left (too deep to be ours) and the stack
    computed, with warnings."""
    X = samples()
    expected = PerDiagramDistance().fit_transform(X)
    stage = PerDiagramDistance(memory=tmp_path)
    stage.fit_transform(X)
    (entry,) = entries(tmp_path)
    entry.unlink()
    nest_folders(entry, 1200)
    try:
        with pytest.warns(CacheWarning, match="is unusable"):
            assert np.array_equal(stage.fit_transform(X), expected)
        assert entry.is_dir()
    finally:
        remove_nested(entry)


@pytest.mark.parametrize("kind", ["file", "fifo"])
def test_a_cache_folder_that_is_not_a_folder_degrades_to_computing(tmp_path, kind):
    """``<memory>/sklearn_meshph_distances`` a file or a FIFO: the clean-up of the
    temporary file raised NotADirectoryError out of the store."""
    if kind == "fifo" and not hasattr(os, "mkfifo"):
        pytest.skip("no FIFOs here")
    folder = tmp_path / "sklearn_meshph_distances"
    folder.write_bytes(b"") if kind == "file" else os.mkfifo(folder)
    X = samples()
    with pytest.warns(CacheWarning, match="cannot be written"):
        result = PerDiagramDistance(memory=tmp_path).fit_transform(X)
    assert np.array_equal(result, PerDiagramDistance().fit_transform(X))


def test_an_empty_stack_is_stored_and_read(tmp_path):
    """A stack with a zero in its shape: the view cast raised TypeError, leaving a
    temporary file behind (no estimator asks for one today: the cache alone)."""
    from sklearn_meshph.diagrams.stack_cache import StackCache

    cache = StackCache(tmp_path)
    stored = cache.stack("0" * 64, (0, 4, 2), np.float64, lambda: np.empty((0, 4, 2)))
    assert stored.shape == cache.load("0" * 64, (0, 4, 2), np.float64).shape == (0, 4, 2)
    assert [p.suffix for p in (cache.folder).iterdir()] == [".npy"]


def test_a_cache_folder_made_a_link_is_never_swept(tmp_path):
    """Whoever can write the memory location made ``sklearn_meshph_distances`` a link
    to the user's home: the sweep of old temporary files followed it and deleted the
    user's own ``.*.tmp`` files and folders there."""
    from sklearn_meshph.diagrams.stack_cache import StackCache
    from sklearn_meshph.spectral.cache import EigenCache, remove_path, sweep_orphans

    home = tmp_path / "home"
    home.mkdir()
    (home / ".notes.tmp").write_text("the user's")
    (home / ".cfg.tmp").mkdir()
    (home / ".cfg.tmp" / "f").write_text("the user's")
    old = 10 * 3600
    for path in (home / ".notes.tmp", home / ".cfg.tmp"):
        os.utime(path, (path.stat().st_atime - old, path.stat().st_mtime - old))
    for name in ("sklearn_meshph_distances", "sklearn_meshph_eigen"):
        (tmp_path / name).symlink_to(home)
    StackCache(tmp_path).store("0" * 64, np.zeros((2, 2)))
    sweep_orphans(EigenCache(tmp_path).folder)  # what the eigen cache's stores do
    remove_path(tmp_path / "sklearn_meshph_eigen" / ".notes.tmp")
    assert (home / ".notes.tmp").read_text() == "the user's"
    assert (home / ".cfg.tmp" / "f").read_text() == "the user's"
