"""The eigen cache stores data only: a crafted entry cannot run code, a bad one is
recomputed, a stale one is never read, writes are atomic, and a read-only folder
degrades to computing."""

import json
import os
import pickle
import stat

import numpy as np
import pytest
from conftest import irregular_ellipsoid, nest_folders, remove_nested

from sklearn_meshph import LaplacianEigenTransformer
from sklearn_meshph.spectral import cache as cache_module
from sklearn_meshph.spectral.cache import CacheWarning, EigenCache, numerics_digest

MESH = irregular_ellipsoid(2, seed=4)

#: The digest of the numerics modules at each NUMERICS_VERSION. A failure here means a
#: module that changes the numbers of a solve was edited: bump NUMERICS_VERSION in
#: sklearn_meshph/spectral/cache.py and record the new digest below.
RECORDED = {
    1: "e46d60da681850581c2406ff48ad1e93ec6094adfeb7a09c8423a8fac8825a8f",
    2: "767e81a128a96ef187d504e515714c98a2d8b1099e2a0ee5b9b8a1c99f5984d7",
    3: "3035946e7d15ffcf070ac5249b131cdf5f877333fb3043815484f1ac92ae2aff",
    5: "19590c5473cb97d826efc07c6a06f7a774f37c471929d498679cd1e175f7356c",
    6: "c4d195cee615487a0bad3496b80ead9e4f4b8fc5b3ebcdb1aca4b061fbbcb67e",
    7: "c50aac24e2bc3f28259e55fcd5daef0bd2ff0b4216e82851522123de7f417393",
    8: "44de1c0414d185a01e314789705064d3fd2e70fdfd201709c716503817178404",
    9: "9624692216247b85cc19d619a958bef33e676ea73de7cebec657df01e2bc1828",
    10: "7c2bee0c484752849147faa8390321a2f3531db50ed9221a07b9d9e811dcf30d",
    11: "686344fe4113588126cfeb7dffe8aeec4e3582390d23c9eba78489c830c7c3c6",
    12: "690189d6ce28f87fa972394b2694aa284f2bddf7dc7906ec5711f312d4f0c742",
    13: "1f272e10b8762cfb2a7eaf9224f143c748fef28c771629ce01547b8c286f616d",
    14: "91197817998fb53203188871e38180619d6f54b78f9e4056b8d93914ea865cef",
    15: "53a8d9ae24048a8296fccb2daa0fbfae5f49f1219285a74359f574268f741ef6",
    16: "d35fc715eefb300a824e8beebc9177271581d1bc427eaa185486ebfc70058bb7",
    17: "85736089ac938d1fd7d8ccfbbabef4a4e523bab054794dd69bb2c1628014159c",
    18: "9582704e15e7913864f3e3b0f5a271bfd0976a95564d1caf6b7586b3877b7865",
    19: "42f9fdd226c721d3cce3aa63b58c411dbf5ee16a89ddfd71ca09263e53a53011",
    20: "f63d8ec9c4ad0b79d492fb0d1ae0699c2822e23c1c9d6887184dcb3ac2b4e1a3",
    21: "a707418df3cfd84d66814111914869fd87dc12b33e7eb8f6dc3465b63a58fdc3",
    22: "183c5373e9df292789cdeb060cb3540669e6fb26e301b2a0d4908672753b250f",
    23: "b2e3d1f2853c3ea94e32f90536e7a84100cf025cb12def32abfb4ff72662fd1b",
    24: "42be770c3a6c6473291dcb44369f3f66940506509dc7d6110b7cc778c36a4ff6",
    25: "e3048a4a497b173fbfce9c18ab092bee21e967854cbbaf1e0404676c18c70c52",
    26: "91d678fd629a2e85712f803bc6e16797642bbfc7d4ba8e323417ae835cf5ff87",
    27: "cabfc750ae3bfb82ebec46f3cb88c0fd35134951ed2ca80baf3a802435ffd53d",
    28: "8549a5256d81b0ad898a849753f61ad5b3bcf70294af76c764fbc847123e2a8a",
    29: "8c78f5b447a4901561aaf61e460b78d67fe907f06d91626e48c0444242999c36",
    30: "66e4e89c7887b5a4a23dab4d4177ab026be99ed7219900e0ac3de8887c326359",
    31: "6d91439d3d7b8e7d8e3da2435ace28ee407f98b63968e5e6144eb631dca33647",
    32: "f90974963086dc5b8269610744221aadd6db814f58c094938c121849eb504403",
    33: "10bfd7336a74495a8fc171a65a8b375ff4cbd71ecfc159344289a9713e092f9a",
    34: "ef8a735bbadf1e3ed4286ec84ffdbdd9ecf0bfb1734093a7833491f3d49cc015",
    35: "e2d0c381ea8f1214db1093693ebc691d265d0f53b27ae5968b36d6991d508de7",
    36: "60866ae029dfc70ab07fd486f96ac877750a51647e55f242f6c954f7f36be12d",
    37: "d5a8049b960faf004cb4ce703a6d30bd2ec36c7dbb38957b8ecba29e970cb329",
    38: "872ead6b24f2ddbc2ff15b3d3ebda5160555bb350bf93067a6fa9ece6e880bb3",
}


def entries(folder):
    return sorted(p.parent for p in folder.rglob("header.json"))


def solve(folder, **params):
    return LaplacianEigenTransformer(memory=str(folder), random_state=0, **params).fit_transform(
        [MESH]
    )[0]


def test_the_numerics_version_is_bumped_when_the_numerics_change():
    assert numerics_digest() == RECORDED[cache_module.NUMERICS_VERSION], (
        "a module of NUMERICS_FILES changed: bump NUMERICS_VERSION and record "
        f"{numerics_digest()!r} for it in tests/test_cache.py"
    )


def test_a_bumped_numerics_version_misses(tmp_path, monkeypatch):
    solve(tmp_path)
    assert len(entries(tmp_path)) == 1
    monkeypatch.setattr(cache_module, "NUMERICS_VERSION", cache_module.NUMERICS_VERSION + 1)
    solve(tmp_path)
    assert len(entries(tmp_path)) == 2  # a new key: the old entry is never read


def test_a_crafted_pickle_in_the_cache_cannot_run_code(tmp_path):
    first = solve(tmp_path)
    (entry,) = entries(tmp_path)
    marker = tmp_path / "pwned"

    class Exploit:
        def __reduce__(self):
            return (os.system, (f"touch {marker}",))

    payload = pickle.dumps(Exploit())
    for name in ("values.npy", "vectors.npy", "header.json"):
        (entry / name).write_bytes(payload)
    # An object array saved by numpy (pickled inside a valid .npy) is refused too.
    np.save(entry / "faces.npy", np.array([Exploit()], dtype=object), allow_pickle=True)
    with pytest.warns(CacheWarning, match="unusable and is recomputed"):
        again = solve(tmp_path)
    assert not marker.exists()
    np.testing.assert_array_equal(again.values, first.values)


@pytest.mark.parametrize(
    "damage",
    [
        "wrong shape",
        "huge header",
        "nan",
        "foreign key",
        "truncated",
        "wrong dtype",
        "flipped",
        "no checksum",
    ],
)
def test_an_unusable_entry_is_recomputed_with_a_warning(tmp_path, damage):
    first = solve(tmp_path)
    (entry,) = entries(tmp_path)
    vectors = np.load(entry / "vectors.npy")
    if damage == "wrong shape":
        np.save(entry / "vectors.npy", vectors[:, :-1])
    elif damage == "huge header":  # claims 10^12 elements: refused before reading
        with open(entry / "values.npy", "wb") as stream:
            np.lib.format.write_array_header_1_0(
                stream, {"descr": "<f8", "fortran_order": False, "shape": (10**12,)}
            )
    elif damage == "nan":
        vectors[0, 0] = np.nan
        np.save(entry / "vectors.npy", vectors)
    elif damage == "foreign key":
        header = json.loads((entry / "header.json").read_text())
        header["key"] = "0" * 64
        (entry / "header.json").write_text(json.dumps(header))
    elif damage == "flipped":  # well-formed, finite, the right shape: only the checksum
        np.save(entry / "vectors.npy", -vectors)  # tells (the sign of each is a choice)
    elif damage == "no checksum":  # an entry of the format before checksums
        header = json.loads((entry / "header.json").read_text())
        del header["sha256"]
        (entry / "header.json").write_text(json.dumps(header))
    elif damage == "truncated":
        data = (entry / "vectors.npy").read_bytes()
        (entry / "vectors.npy").write_bytes(data[: len(data) // 2])
    else:
        np.save(entry / "values.npy", np.load(entry / "values.npy").astype(np.float32))
    with pytest.warns(CacheWarning, match="unusable and is recomputed"):
        again = solve(tmp_path)
    np.testing.assert_array_equal(again.values, first.values)
    assert again.spectrum is not None
    # The entry was replaced: the next run reads it without a warning.
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error", CacheWarning)
        np.testing.assert_array_equal(solve(tmp_path).values, first.values)


def test_hits_give_the_same_result_as_a_solve(tmp_path):
    uncached = LaplacianEigenTransformer(random_state=0).fit_transform([MESH])[0]
    first, second = solve(tmp_path), solve(tmp_path)
    for field in (first, second):
        np.testing.assert_array_equal(field.values, uncached.values)
        np.testing.assert_array_equal(field.eigenvalues, uncached.eigenvalues)
        assert field.cleaning == uncached.cleaning


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="needs POSIX, non-root")
def test_a_read_only_folder_degrades_to_computing(tmp_path):
    folder = tmp_path / "shared"
    folder.mkdir()
    folder.chmod(stat.S_IRUSR | stat.S_IXUSR)
    try:
        with pytest.warns(CacheWarning, match="cannot be written"):
            field = solve(folder)
        assert np.isfinite(field.values).all() and not entries(folder)
    finally:
        folder.chmod(stat.S_IRWXU)


def test_writes_are_atomic_and_orphans_are_swept(tmp_path):
    cache = EigenCache(tmp_path)
    solve(tmp_path)
    orphan = cache.folder / ".deadbeef.1.0.tmp"
    orphan.mkdir()
    old = 10 * cache_module._STALE_TEMPORARY
    os.utime(orphan, (orphan.stat().st_atime - old, orphan.stat().st_mtime - old))
    fresh = cache.folder / ".cafe.2.0.tmp"  # a writer at work right now: kept
    fresh.mkdir()
    solve(tmp_path, laplacian="graph")  # another entry: its writer sweeps
    assert not orphan.exists() and fresh.exists()
    assert not [p for p in cache.folder.iterdir() if p.suffix == ".tmp" and p != fresh]


def test_a_folder_that_cannot_be_made_degrades_to_computing(tmp_path):
    # A file where the cache folder should be: writing fails for any user, root too.
    blocked = tmp_path / "not-a-folder"
    blocked.write_text("")
    with pytest.warns(CacheWarning, match="cannot be written"):
        field = solve(blocked)
    reference = LaplacianEigenTransformer(random_state=0).fit_transform([MESH])[0]
    np.testing.assert_array_equal(field.values, reference.values)


def within(seconds, function):
    """``function()``, failing (instead of hanging) when it takes over ``seconds``."""
    import threading

    outcome = {}

    def run():
        try:
            outcome["value"] = function()
        except BaseException as error:  # re-raised in the test's thread
            outcome["error"] = error

    worker = threading.Thread(target=run, daemon=True)
    worker.start()
    worker.join(seconds)
    assert not worker.is_alive(), f"no answer within {seconds} s: a hang"
    if "error" in outcome:
        raise outcome["error"]
    return outcome["value"]


def _header(entry):
    return json.loads((entry / "header.json").read_text())


def _replace_with(path, kind, tmp_path):
    """Put a FIFO, a folder or a symbolic link (to a copy) where the file ``path`` is."""
    copy = tmp_path / f"elsewhere-{path.name}"
    copy.write_bytes(path.read_bytes())
    path.unlink()
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "folder":
        path.mkdir()
    else:  # a link to a perfectly good copy: still not a regular file of the entry
        path.symlink_to(copy)


TAMPERED_HEADERS = {
    "a string count": lambda h: {**h, "n_vertices": str(h["n_vertices"])},
    "a float count": lambda h: {**h, "n_pairs": float(h["n_pairs"])},
    "a list": lambda h: [h],
    "a list report": lambda h: {**h, "report": list(h["report"].values())},
    "a string in the report": lambda h: {**h, "report": {**h["report"], "n_welded": "0"}},
    "no edge count": lambda h: {k: v for k, v in h.items() if k != "n_edges"},
    "a negative edge count": lambda h: {**h, "n_edges": -1},
    "edges for a mesh": lambda h: {**h, "n_edges": 1},
    # A 401-digit integer: OverflowError (not a ValueError) once made a float.
    "a huge share": lambda h: {**h, "report": {**h["report"], "vertex_share": 10**400}},
}


@pytest.mark.parametrize("damage", sorted(TAMPERED_HEADERS))
def test_a_header_of_the_wrong_types_is_recomputed(tmp_path, damage):
    first = solve(tmp_path)
    (entry,) = entries(tmp_path)
    (entry / "header.json").write_text(json.dumps(TAMPERED_HEADERS[damage](_header(entry))))
    with pytest.warns(CacheWarning, match="unusable and is recomputed"):
        again = solve(tmp_path)
    np.testing.assert_array_equal(again.values, first.values)
    assert again.cleaning == first.cleaning


@pytest.mark.parametrize("constant", ["Infinity", "-Infinity", "NaN"])
@pytest.mark.parametrize("where", ["n_pairs", "area_share"])
def test_json_constants_in_a_header_are_refused(tmp_path, constant, where):
    first = solve(tmp_path)
    (entry,) = entries(tmp_path)
    header = _header(entry)
    if where == "n_pairs":
        header["n_pairs"] = "@"
    else:
        header["report"]["area_share"] = "@"
    text = json.dumps(header).replace('"@"', constant)
    (entry / "header.json").write_text(text)
    with pytest.warns(CacheWarning, match="unusable and is recomputed: the header holds"):
        again = solve(tmp_path)
    np.testing.assert_array_equal(again.values, first.values)
    assert again.cleaning == first.cleaning


def test_an_array_whose_size_overflows_is_recomputed(tmp_path):
    first = solve(tmp_path)
    (entry,) = entries(tmp_path)
    with open(entry / "vectors.npy", "wb") as stream:  # 2**63 values: beyond int64
        np.lib.format.write_array_header_1_0(
            stream, {"descr": "<f8", "fortran_order": False, "shape": (2**62, 2)}
        )
    with pytest.warns(CacheWarning, match="unusable and is recomputed"):
        again = solve(tmp_path)
    np.testing.assert_array_equal(again.values, first.values)


def test_a_deeply_nested_header_is_recomputed(tmp_path):
    first = solve(tmp_path)
    (entry,) = entries(tmp_path)
    depth = 30000  # under the header's size limit, far over the recursion limit
    (entry / "header.json").write_text("[" * depth + "]" * depth)
    with pytest.warns(CacheWarning, match="unusable and is recomputed"):
        again = solve(tmp_path)
    np.testing.assert_array_equal(again.values, first.values)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs and symbolic links")
@pytest.mark.parametrize("kind", ["fifo", "folder", "link"])
@pytest.mark.parametrize("name", ["header.json", "values.npy", "vectors.npy", "edges.npy"])
def test_only_regular_files_of_an_entry_are_opened(tmp_path, kind, name):
    first = solve(tmp_path)
    (entry,) = entries(tmp_path)
    _replace_with(entry / name, kind, tmp_path)
    with pytest.warns(CacheWarning, match=f"unusable and is recomputed: {name} is not a regular"):
        again = within(30, lambda: solve(tmp_path))
    np.testing.assert_array_equal(again.values, first.values)
    # The entry was replaced by a good one.
    assert (entry / name).is_file() and not (entry / name).is_symlink()
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error", CacheWarning)
        np.testing.assert_array_equal(within(30, lambda: solve(tmp_path)).values, first.values)


@pytest.mark.skipif(os.name != "posix", reason="needs symbolic links")
def test_an_entry_that_is_a_link_is_not_followed(tmp_path):
    import shutil

    first = solve(tmp_path)
    (entry,) = entries(tmp_path)
    elsewhere = tmp_path / "elsewhere"
    shutil.move(entry, elsewhere)
    entry.symlink_to(elsewhere, target_is_directory=True)
    with pytest.warns(CacheWarning, match="unusable and is recomputed: not a folder"):
        again = solve(tmp_path)
    np.testing.assert_array_equal(again.values, first.values)
    assert entry.is_dir() and not entry.is_symlink()
    assert (elsewhere / "header.json").exists()  # what the link pointed to is left alone


@pytest.mark.parametrize("memory", [""])
def test_an_empty_memory_path_is_refused(memory):
    from sklearn_meshph import make_mesh_distance

    with pytest.raises(ValueError, match="memory must be a folder.*got an empty path"):
        LaplacianEigenTransformer(memory=memory).fit_transform([MESH])
    with pytest.raises(ValueError, match="memory must be a folder.*got an empty path"):
        make_mesh_distance(memory=memory)


def test_concurrent_writers_keep_each_others_entries(tmp_path):
    """Two processes that both missed an entry both store it. The second removed the
    first's fresh entry before renaming its own (under the first's readers, who then
    warned that it was unusable and recomputed); it now keeps the entry there."""
    first = solve(tmp_path)
    (entry,) = entries(tmp_path)
    placed = os.stat(entry).st_ino
    late = EigenCache(tmp_path)  # a writer whose load missed before the first stored
    key = entry.name
    stored = EigenCache(tmp_path).load(key, len(MESH[0]), 10**6)
    late.store(key, stored)
    assert os.stat(entry).st_ino == placed  # the first writer's entry, untouched
    assert [p.name for p in late.folder.iterdir()] == [key]  # no temporary left
    # An entry its own load found unusable is replaced, whole.
    (entry / "values.npy").write_bytes(b"damaged")
    with pytest.warns(CacheWarning, match="unusable and is recomputed"):
        again = solve(tmp_path)
    assert os.stat(entry).st_ino != placed
    np.testing.assert_array_equal(again.values, first.values)
    assert [p.name for p in late.folder.iterdir()] == [key]


def _age(path):
    old = 10 * cache_module._STALE_TEMPORARY
    os.utime(path, (path.lstat().st_atime - old, path.lstat().st_mtime - old))


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="needs POSIX, non-root")
def test_an_unusable_read_only_entry_is_replaced_and_nothing_is_left(tmp_path):
    """The entry was moved aside and replaced, but the folder moved aside could not be
    emptied (nor by the sweeper later): its owner had no write permission on it."""
    first = solve(tmp_path)
    (entry,) = entries(tmp_path)
    (entry / "values.npy").write_bytes(b"damaged")
    entry.chmod(stat.S_IRUSR | stat.S_IXUSR)
    with pytest.warns(CacheWarning, match="unusable and is recomputed"):
        again = solve(tmp_path)
    np.testing.assert_array_equal(again.values, first.values)
    assert [p.name for p in entry.parent.iterdir()] == [entry.name]
    assert stat.S_IMODE(entry.stat().st_mode) & stat.S_IWUSR  # ours, written again


@pytest.mark.skipif(os.name != "posix", reason="needs POSIX")
def test_hostile_orphans_are_swept_without_recursion_or_following_links(tmp_path):
    """An orphan nested thousands of folders deep made the sweeper (and so every store)
    raise RecursionError; one holding a link must not reach what the link points to."""
    cache = EigenCache(tmp_path)
    cache.folder.mkdir(parents=True)
    deep = cache.folder / ".deep.1.a.tmp"
    nest_folders(deep, 1200)
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "keep.txt").write_text("not the cache's")
    linked = cache.folder / ".linked.2.b.tmp"
    linked.mkdir()
    (linked / "to-outside").symlink_to(outside)
    (linked / "file").write_text("")
    read_only = cache.folder / ".ro.3.c.tmp"
    nest_folders(read_only, 2)
    (read_only / "d").chmod(stat.S_IRUSR | stat.S_IXUSR)
    for path in (deep, linked, read_only):
        _age(path)
    try:
        field = solve(tmp_path)  # stores: sweeps
        assert deep.exists()  # deeper than any entry: left, but no error
    finally:
        remove_nested(deep)
    assert np.isfinite(field.values).all()
    assert not linked.exists() and not read_only.exists()
    assert (outside / "keep.txt").read_text() == "not the cache's"
    cache_module.remove_path(outside / "keep.txt")
    assert not (outside / "keep.txt").exists()
    cache_module.remove_path(tmp_path / "nothing here")  # nothing: no error


@pytest.mark.skipif(os.name != "posix", reason="needs POSIX")
def test_removal_sets_no_mode_through_a_name_swapped_for_a_link(tmp_path):
    """The permissions of a folder lacking the owner's were set by name, following a
    link swapped in since the folder was looked at, with the folder's own bits (set-id
    included): whoever could write the cache folder could make a file of the user's
    world-writable and setuid. They are set through a descriptor of the folder looked
    at, to the owner's read, write and search bits added to its permissions, no set-id
    bit."""
    folder = tmp_path / "cache"
    folder.mkdir()
    victim = tmp_path / "victim"
    victim.write_text("the user's")
    victim.chmod(0o600)
    looked_at = folder / ".x.tmp"
    looked_at.mkdir()
    looked_at.chmod(0o6077)
    info = os.stat(looked_at, follow_symlinks=False)
    os.rename(looked_at, folder / ".moved.tmp")  # the swap, after the look
    os.symlink(victim, looked_at)
    parent = os.open(folder, os.O_RDONLY)
    try:
        assert cache_module._open_folder(parent, ".x.tmp", info) is None
    except OSError:
        pass  # refused to open the link: as good
    finally:
        os.close(parent)
    assert stat.S_IMODE(victim.stat().st_mode) == 0o600
    cache_module.remove_path(folder / ".moved.tmp")  # the folder itself: no set-id kept
    assert not (folder / ".moved.tmp").exists()
    (folder / ".moved.tmp").mkdir()
    (folder / ".moved.tmp").chmod(0o6077)
    info = os.stat(folder / ".moved.tmp")
    parent = os.open(folder, os.O_RDONLY)
    inner = cache_module._open_folder(parent, ".moved.tmp", info)
    os.close(inner)
    os.close(parent)
    assert stat.S_IMODE(os.stat(folder / ".moved.tmp").st_mode) == 0o777
