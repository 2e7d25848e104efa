"""Mesh files as users have them: compressed, malformed, hostile, in untidy folders."""

import bz2
import gzip
import lzma
import os
import struct
import subprocess
import sys
import time
import tracemalloc
import zlib
from pathlib import Path

import numpy as np
import pytest
import trimesh

from sklearn_meshph import check_mesh, load_mesh_folder
from sklearn_meshph.datasets import MESH_EXTENSIONS, SkippedFilesWarning
from sklearn_meshph.mesh import reading
from sklearn_meshph.mesh.reading import read_mesh_file, split_compression
from sklearn_meshph.pointcloud.reading import read_sample_file

COMPRESSORS = {".gz": gzip.compress, ".bz2": bz2.compress, ".xz": lzma.compress}


@pytest.fixture
def sphere():
    return trimesh.creation.icosphere(2)


def traced_peak(call, refused=None):
    """``(result, peak)``: what ``call()`` returns and the peak of the memory it
    allocates through NumPy and Python (tracemalloc); with ``refused``, the call must
    raise a ``ValueError`` matching it (the result is then None)."""
    tracemalloc.start()
    try:
        if refused is None:
            result = call()
        else:
            result = None
            with pytest.raises(ValueError, match=refused):
                call()
        return result, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def write(path, mesh):
    mesh.export(path)
    return path


def compress(path, compression):
    """``path`` compressed next to itself as ``<name><compression>``."""
    out = path.with_name(path.name + compression)
    out.write_bytes(COMPRESSORS[compression](path.read_bytes()))
    return out


@pytest.mark.parametrize("compression", [".gz", ".bz2", ".xz"])
@pytest.mark.parametrize("ext", [".off", ".obj", ".ply"])
def test_compressed_files_read_as_the_plain_file(tmp_path, sphere, ext, compression):
    plain = write(tmp_path / f"a{ext}", sphere)
    packed = compress(plain, compression)
    expected = check_mesh(plain)
    for actual in (check_mesh(packed), check_mesh(str(packed))):
        for a, b in zip(actual, expected, strict=True):
            assert a.dtype == b.dtype
            np.testing.assert_array_equal(a, b)
    mesh = read_mesh_file(packed)
    np.testing.assert_array_equal(mesh.faces, expected[1])


def test_upper_case_names_and_split_compression(tmp_path, sphere):
    packed = compress(write(tmp_path / "A.OFF", sphere), ".gz")
    packed = packed.rename(tmp_path / "B.OFF.GZ")
    assert split_compression(packed) == ("off", ".gz")
    assert len(check_mesh(packed)[1]) == len(sphere.faces)


def test_stl_and_triangle_soup_obj_load(tmp_path, sphere):
    stl = write(tmp_path / "a.stl", sphere)
    vertices, faces = check_mesh(stl)
    # STL is a triangle soup: three vertices per face, as in the file (no welding here).
    assert faces.shape == sphere.faces.shape
    assert vertices.shape == (3 * len(sphere.faces), 3)
    soup = sphere.vertices[sphere.faces].reshape(-1, 3)
    lines = [f"v {x} {y} {z}" for x, y, z in soup]
    lines += [f"f {3 * k + 1} {3 * k + 2} {3 * k + 3}" for k in range(len(sphere.faces))]
    obj = tmp_path / "soup.obj"
    obj.write_text("\n".join(lines) + "\n")
    mesh = read_mesh_file(obj)
    assert isinstance(mesh, trimesh.Trimesh)
    vertices, faces = check_mesh(obj)
    assert vertices.dtype == np.float64 and faces.dtype == np.int64
    assert faces.shape == sphere.faces.shape and len(vertices) == 3 * len(faces)
    np.testing.assert_allclose(vertices[faces[0]], sphere.vertices[sphere.faces[0]])


def test_truncated_file_is_named(tmp_path):
    path = tmp_path / "cut.off"
    path.write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n")
    with pytest.raises(ValueError, match=r"^mesh: .*cut\.off"):
        check_mesh(path)
    with pytest.raises(ValueError, match=r"^sample 2: .*cut\.off"):
        check_mesh(path, index=2)


def test_truncated_archive_is_named(tmp_path, sphere):
    packed = compress(write(tmp_path / "a.off", sphere), ".gz")
    cut = tmp_path / "cut.off.gz"
    cut.write_bytes(packed.read_bytes()[: packed.stat().st_size // 2])
    with pytest.raises(ValueError, match=r"cannot decompress .*cut\.off\.gz"):
        check_mesh(cut)
    fake = tmp_path / "fake.off.xz"
    fake.write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")  # not compressed
    with pytest.raises(ValueError, match=r"cannot decompress .*fake\.off\.xz"):
        check_mesh(fake)


@pytest.mark.parametrize("compression", [None, ".gz"])
def test_a_header_claiming_too_many_vertices_fails_fast(tmp_path, compression):
    path = tmp_path / "liar.off"
    path.write_text("OFF\n100000000 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    if compression:
        path = compress(path, compression)
    start = time.perf_counter()
    _, peak = traced_peak(lambda: check_mesh(path), r"liar\.off")
    assert time.perf_counter() - start < 5.0
    assert peak < 50 * 2**20  # 1e8 vertices would be 2.4 GB


def test_a_ply_header_claiming_too_many_vertices_fails(tmp_path):
    header = (
        "ply\nformat {}\nelement vertex 100000000\nproperty float x\nproperty float y\n"
        "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
        "end_header\n"
    )
    ascii_ply = tmp_path / "liar.ply"
    ascii_ply.write_text(header.format("ascii 1.0") + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    binary_ply = tmp_path / "liar_binary.ply"
    binary_ply.write_bytes(
        header.format("binary_little_endian 1.0").encode()
        + np.eye(3, dtype="<f4").tobytes()
        + b"\x03"
        + np.arange(3, dtype="<i4").tobytes()
    )
    for path in (ascii_ply, binary_ply):
        start = time.perf_counter()
        with pytest.raises(ValueError, match=path.name):
            check_mesh(path)
        assert time.perf_counter() - start < 5.0


def test_a_compression_bomb_is_refused(tmp_path, monkeypatch):
    # 64 MiB of zeros compress to about 64 KiB; with a 1 MiB limit it is refused after
    # reading about the limit, not the whole content.
    bomb = tmp_path / "bomb.off.gz"
    with gzip.open(bomb, "wb") as stream:
        chunk = b"\0" * 2**20
        for _ in range(64):
            stream.write(chunk)
    assert bomb.stat().st_size < 2**20
    with pytest.raises(ValueError, match=r"bomb\.off\.gz.* decompresses to more than 1048576"):
        read_mesh_file(bomb, max_decompressed_size=2**20)
    monkeypatch.setattr(reading, "MAX_DECOMPRESSED_SIZE", 2**20)
    _, peak = traced_peak(lambda: check_mesh(bomb), r"^mesh: .*bomb\.off\.gz.* more than")
    assert peak < 16 * 2**20
    root = tmp_path / "folder"
    (root / "a").mkdir(parents=True)
    bomb.rename(root / "a" / "bomb.off.gz")
    with pytest.raises(ValueError, match=r"^sample 0: .*bomb\.off\.gz"):
        load_mesh_folder(root)


def test_default_limit_is_documented():
    assert reading.MAX_DECOMPRESSED_SIZE == 2 * 1024**3
    assert "MAX_DECOMPRESSED_SIZE" in read_mesh_file.__doc__


def test_a_file_exactly_at_the_limit_is_read(tmp_path, sphere):
    plain = write(tmp_path / "a.off", sphere)
    packed = compress(plain, ".bz2")
    size = plain.stat().st_size
    assert len(read_mesh_file(packed, max_decompressed_size=size).faces) == len(sphere.faces)
    with pytest.raises(ValueError, match="more than"):
        read_mesh_file(packed, max_decompressed_size=size - 1)


def test_directory_missing_empty_and_unknown(tmp_path):
    folder = tmp_path / "dir.off"
    folder.mkdir()
    with pytest.raises(ValueError, match=r"dir\.off.* is a directory"):
        check_mesh(folder)
    with pytest.raises(ValueError, match=r"missing\.off.* does not exist"):
        check_mesh(tmp_path / "missing.off")
    with pytest.raises(ValueError, match=r"missing\.off\.gz.* does not exist"):
        check_mesh(str(tmp_path / "missing.off.gz"))
    empty = tmp_path / "empty.obj"
    empty.touch()
    with pytest.raises(ValueError, match=r"empty\.obj.* is empty"):
        check_mesh(empty)
    empty_gz = tmp_path / "empty.obj.gz"
    empty_gz.write_bytes(gzip.compress(b""))
    with pytest.raises(ValueError, match=r"empty\.obj\.gz.* empty once decompressed"):
        check_mesh(empty_gz)
    nameless = tmp_path / "mesh.gz"
    nameless.write_bytes(gzip.compress(b"OFF\n"))
    with pytest.raises(ValueError, match=r"cannot tell the mesh format of .*mesh\.gz"):
        check_mesh(nameless)
    text = tmp_path / "notes.txt"
    text.write_text("not a mesh\n")
    with pytest.raises(ValueError, match=r"notes\.txt"):
        check_mesh(text)


def test_mixed_folder_and_single_mesh_class(tmp_path, sphere):
    (tmp_path / "balls").mkdir()
    (tmp_path / "boxes").mkdir()
    (tmp_path / "docs").mkdir()
    (tmp_path / ".hidden").mkdir()
    write(tmp_path / "balls" / "a.off", sphere)
    compress(write(tmp_path / "balls" / "b.obj", sphere), ".xz").touch()
    (tmp_path / "balls" / "b.obj").unlink()
    write(tmp_path / "boxes" / "only.ply", trimesh.creation.box())
    (tmp_path / "balls" / "README.md").write_text("about balls\n")
    (tmp_path / "balls" / "thumb.png").write_bytes(b"\x89PNG")
    (tmp_path / "balls" / "archive.tar.gz").write_bytes(gzip.compress(b"x"))
    (tmp_path / "balls" / "sub").mkdir()
    (tmp_path / "docs" / "notes.txt").write_text("nothing\n")
    write(tmp_path / ".hidden" / "x.off", sphere)
    (tmp_path / "top.off").write_text("OFF\n")
    data = load_mesh_folder(tmp_path)
    assert data.target_names.tolist() == ["balls", "boxes"]
    assert data.target.tolist() == [0, 0, 1]
    assert [Path(f).name for f in data.filenames] == ["a.off", "b.obj.xz", "only.ply"]
    assert [len(m.faces) for m in data.data] == [len(sphere.faces)] * 2 + [12]
    assert set(data) >= {"data", "target", "target_names", "filenames", "DESCR"}


def test_default_extensions_include_compressed_variants():
    for ext in (".obj", ".ply", ".off", ".stl", ".glb"):
        assert ext in MESH_EXTENSIONS
        for compression in (".gz", ".bz2", ".xz"):
            assert ext + compression in MESH_EXTENSIONS


def test_parallel_loading_keeps_order(tmp_path, capsys):
    for k, name in enumerate(["c", "a", "b"]):
        (tmp_path / name).mkdir()
        for j in range(3):
            mesh = trimesh.creation.icosphere(1)
            mesh = trimesh.Trimesh(mesh.vertices * (1 + 3 * k + j), mesh.faces, process=False)
            compress(write(tmp_path / name / f"{j}.off", mesh), ".gz")
            (tmp_path / name / f"{j}.off").unlink()
    serial = load_mesh_folder(tmp_path)
    parallel = load_mesh_folder(tmp_path, n_jobs=2, verbose=1)
    assert serial.filenames.tolist() == parallel.filenames.tolist()
    assert serial.target.tolist() == parallel.target.tolist() == [0] * 3 + [1] * 3 + [2] * 3
    for a, b in zip(serial.data, parallel.data, strict=True):
        np.testing.assert_array_equal(a.vertices, b.vertices)
        np.testing.assert_array_equal(a.faces, b.faces)
    assert "reading files" in capsys.readouterr().err
    load_mesh_folder(tmp_path, verbose=0)
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize(
    "params",
    [
        {"n_jobs": "two"},
        {"verbose": -1},
        {"n_jobs": 1.5},
        {"extensions": ".off"},
        {"load": "yes"},
        {"on_error": "ignore"},
    ],
)
def test_load_mesh_folder_parameters_are_checked(tmp_path, sphere, params):
    # A readable mesh in the folder: only the parameter can be what is refused.
    (tmp_path / "balls").mkdir()
    write(tmp_path / "balls" / "a.off", sphere)
    assert len(load_mesh_folder(tmp_path).data) == 1
    (name,) = params
    with pytest.raises((ValueError, TypeError), match=rf"'{name}' parameter of load_mesh_folder"):
        load_mesh_folder(tmp_path, **params)


def _png() -> bytes:
    """A valid one-pixel PNG image."""

    def chunk(kind, data):
        return (
            struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
        )

    header = struct.pack(">IIBBBBB", 1, 1, 8, 2, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", header)
        + chunk(b"IDAT", zlib.compress(b"\x00\xff\x00\x00"))
        + chunk(b"IEND", b"")
    )


NOT_MESHES = {
    "notes.off.gz": gzip.compress(b"hello"),
    "plain_text.off.gz": b"hello",
    "picture.obj": _png(),
    "picture.off": _png(),
    "picture.ply": _png(),
    "picture.stl": _png(),
    "picture.glb": _png(),
    "text.obj": b"hello world\n",
    "text.ply": b"hello\n",
    "empty.off": b"",
}


@pytest.mark.parametrize("name", sorted(NOT_MESHES))
def test_a_file_that_is_not_a_mesh_is_one_clear_line(tmp_path, name):
    path = tmp_path / name
    path.write_bytes(NOT_MESHES[name])
    with pytest.raises(ValueError, match=r"^sample 3: ") as info:
        read_mesh_file(path, "sample 3")
    message = str(info.value)
    assert "\n" not in message and name in message and "not a valid" in message
    # Not the parser's own words (trimesh's, gzip's, Python's).
    for leaked in ("unpack", "Not a", "header", "gzipped", "expected", "Errno"):
        assert leaked not in message


def _folder_with_bad_files(root, sphere):
    for name in ("balls", "boxes", "bad"):
        (root / name).mkdir(parents=True)
    write(root / "balls" / "a.off", sphere)
    write(root / "balls" / "c.off", sphere)
    write(root / "boxes" / "b.ply", trimesh.creation.box())
    (root / "balls" / "b.off.gz").write_bytes(gzip.compress(b"hello"))
    (root / "boxes" / "a.obj").write_bytes(_png())
    (root / "bad" / "only.stl").write_bytes(b"")
    return root


def test_unreadable_files_are_skipped_on_request(tmp_path, sphere):
    root = _folder_with_bad_files(tmp_path / "data", sphere)
    with pytest.raises(ValueError, match=r"^sample 0: .*only\.stl.* not a valid"):
        load_mesh_folder(root)
    with pytest.warns(SkippedFilesWarning, match=r"3 file\(s\) .* skipped: .*b\.off\.gz") as caught:
        data = load_mesh_folder(root, on_error="skip")
    assert len(caught) == 1 and "a.obj" in str(caught[0].message)
    assert [Path(f).name for f in data.filenames] == ["a.off", "c.off", "b.ply"]
    # The class whose only file is unreadable is no class; labels stay consecutive.
    assert data.target_names.tolist() == ["balls", "boxes"]
    assert data.target.tolist() == [0, 0, 1]
    assert [Path(f).name for f, _ in data.skipped] == ["only.stl", "b.off.gz", "a.obj"]
    assert all("not a valid" in reason for _, reason in data.skipped)
    assert all(not reason.startswith("sample") for _, reason in data.skipped)
    with pytest.warns(SkippedFilesWarning):
        parallel = load_mesh_folder(root, on_error="skip", n_jobs=2)
    assert parallel.filenames.tolist() == data.filenames.tolist()
    assert load_mesh_folder(root, on_error="skip", load=False).skipped == []


def test_entries_named_like_samples_that_are_not_files_are_named_not_dropped(tmp_path, sphere):
    """Found probing the main job (stop 52): a FIFO, a folder and a broken link named
    like meshes were left out of their class without a word (18 meshes read of 22)."""
    (tmp_path / "balls").mkdir()
    sphere.export(tmp_path / "balls" / "a.off")
    sphere.export(tmp_path / "balls" / "b.off")
    os.mkfifo(tmp_path / "balls" / "fifo.off")  # reading it would block forever
    (tmp_path / "balls" / "folder.off").mkdir()
    (tmp_path / "balls" / "gone.off").symlink_to(tmp_path / "absent.off")
    with pytest.raises(ValueError, match=r"^sample 2: .*fifo\.off' is not a regular file"):
        load_mesh_folder(tmp_path)
    with pytest.warns(SkippedFilesWarning, match=r"3 file\(s\)"):
        data = load_mesh_folder(tmp_path, on_error="skip")
    assert [Path(f).name for f in data.filenames] == ["a.off", "b.off"]
    reasons = dict((Path(f).name, reason) for f, reason in data.skipped)
    assert "is not a regular file" in reasons["fifo.off"]
    assert "is a directory" in reasons["folder.off"]
    assert "is not a regular file" in reasons["gone.off"]


def test_skipping_every_file_is_an_error(tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "x.off").write_text("hello")
    with pytest.raises(ValueError, match=r"none of the 1 files .* be read; the first: .*x\.off"):
        load_mesh_folder(tmp_path, on_error="skip")


def test_reading_modules_share_public_decompression():
    import ast
    import inspect

    from sklearn_meshph.pointcloud import reading as cloud_reading

    tree = ast.parse(inspect.getsource(cloud_reading))
    imported = [a.name for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) for a in n.names]
    assert imported and not [name for name in imported if name.startswith("_")]
    assert {"LimitedReader", "decompress"} <= set(reading.__all__)


def test_load_watertight_folder(watertight_dir):
    data = load_mesh_folder(watertight_dir, n_jobs=2)
    assert len(data.data) == 200
    assert len(data.target_names) == 20
    assert np.bincount(data.target).tolist() == [10] * 20
    assert all(f.endswith(".off.gz") for f in data.filenames)
    vertices, faces = check_mesh(data.filenames[0])
    np.testing.assert_array_equal(vertices, data.data[0].vertices)
    np.testing.assert_array_equal(faces, data.data[0].faces)


def test_archives_and_containers_are_refused_before_trimesh_opens_them(tmp_path, sphere):
    import zipfile

    inner = write(tmp_path / "inner.off", sphere)
    # A zip bomb in miniature: trimesh would open the archive and inflate its members.
    bomb = tmp_path / "shapes.zip"
    with zipfile.ZipFile(bomb, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.write(inner, "inner.off")
        archive.writestr("zeros.off", b"\0" * 10_000_000)
    with pytest.raises(ValueError, match=r"shapes\.zip.* is a \.zip file.*archives"):
        check_mesh(bomb)
    for name in ("model.3mf", "scene.tar", "x.dae"):
        other = tmp_path / name
        other.write_bytes(bomb.read_bytes())
        with pytest.raises(ValueError, match="formats read are .obj, .ply, .off, .stl, .glb"):
            check_mesh(other)
    # A zip whatever its name (plain or compressed) is refused too.
    disguised = tmp_path / "disguised.stl"
    disguised.write_bytes(bomb.read_bytes())
    with pytest.raises(ValueError, match=r"disguised\.stl.* is a zip archive"):
        check_mesh(disguised)
    compressed = tmp_path / "disguised.off.gz"
    compressed.write_bytes(gzip.compress(bomb.read_bytes()))
    with pytest.raises(ValueError, match=r"disguised\.off\.gz.* is a zip archive"):
        check_mesh(compressed)
    assert reading.MESH_FORMATS == ("obj", "ply", "off", "stl", "glb")


@pytest.mark.parametrize("compression", [None, ".gz"])
def test_text_point_cloud_peak_memory_within_twice_the_file(tmp_path, compression):
    from sklearn_meshph.pointcloud.reading import read_point_cloud_file

    points = np.random.default_rng(0).normal(size=(100_000, 3))
    text = "# a scan\n" + "\n".join(f"{x:.6f} {y:.6f} {z:.6f}" for x, y, z in points) + "\n"
    path = tmp_path / "scan.xyz"
    path.write_text(text)
    size = path.stat().st_size
    if compression:
        path = compress(path, compression)
    loaded, peak = traced_peak(lambda: read_point_cloud_file(path))
    np.testing.assert_allclose(loaded, points, atol=1e-6)
    assert peak <= 2 * size, (peak, size)


def test_text_point_cloud_errors_name_the_line(tmp_path):
    from sklearn_meshph.pointcloud.reading import read_point_cloud_file

    path = tmp_path / "scan.xyz"
    path.write_text("3\n0 0 0\n# comment\n1 1 1\n2 2\n")
    with pytest.raises(ValueError, match=r"scan\.xyz'?: line 5 holds 2 numbers where the first"):
        read_point_cloud_file(path)
    path.write_text("0 0 0\n1 x 1\n")
    with pytest.raises(ValueError, match=r"scan\.xyz'?: line 2 holds something other than"):
        read_point_cloud_file(path)
    path.write_text("7\n1 2 3 4\n5 6 7 8\n")
    np.testing.assert_array_equal(read_point_cloud_file(path), [[1, 2, 3], [5, 6, 7]])


def test_text_point_cloud_refuses_long_lines_and_carriage_returns(tmp_path):
    from sklearn_meshph.pointcloud.reading import MAX_LINE_LENGTH, read_point_cloud_file

    # A 0.5 MB gzip of one 6 MB line: before, the line was held and split (7 GB for 170
    # of them); now it is refused at MAX_LINE_LENGTH bytes.
    bomb = tmp_path / "bomb.xyz.gz"
    bomb.write_bytes(gzip.compress(b"12 " * 2_000_000))
    with pytest.raises(ValueError, match=rf"line 1 is longer than {MAX_LINE_LENGTH} bytes"):
        read_point_cloud_file(bomb)
    lone = tmp_path / "mac.xyz"
    lone.write_bytes(b"0 0 0\r1 0 0\r0 1 0\r0 0 1\r")
    with pytest.raises(ValueError, match=r"line 1 holds carriage returns"):
        read_point_cloud_file(lone)
    windows = tmp_path / "windows.xyz"
    windows.write_bytes(b"0 0 0\r\n1 0 0\r\n0 1 0\r\n")
    assert read_point_cloud_file(windows).shape == (3, 3)
    underscore = tmp_path / "underscore.xyz"  # float() reads 1_0, NumPy does not
    underscore.write_bytes(b"0 0 0\n0 1_0 0\n")
    with pytest.raises(ValueError, match=r"line 2 holds something other than numbers"):
        read_point_cloud_file(underscore)


@pytest.mark.parametrize("compress", [gzip.compress, lambda data: data])
def test_a_ply_declaring_too_many_rows_is_refused_before_it_is_read(tmp_path, compress):
    """Found by an adversarial review: a 2 MB .ply.gz of 180 million zero vertices (2 GiB
    decompressed, within the bytes limit) took 12.5 GB in trimesh, then was called "not
    parsable". Its header is read first; the rest is never decompressed."""
    from sklearn_meshph.mesh.reading import MAX_PLY_ROWS

    header = (
        b"ply\nformat binary_little_endian 1.0\nelement vertex 178869589\n"
        b"property float x\nproperty float y\nproperty float z\nend_header\n"
    )
    path = tmp_path / ("bomb.ply.gz" if compress is gzip.compress else "bomb.ply")
    path.write_bytes(compress(header + bytes(12 * 1024**2)))
    message = rf"declares 178869589 vertex rows, more than MAX_PLY_ROWS \({MAX_PLY_ROWS}\)"
    _, peak = traced_peak(lambda: read_sample_file(path, "sample 0"), "sample 0: .*" + message)
    assert peak < 4 * 1024**2
    # Comments pushing the counts beyond the header's first 64 KiB do not hide them.
    long_header = header.replace(b"element", b"comment x\n" * 8000 + b"element", 1)
    path.write_bytes(compress(long_header + bytes(12 * 1024**2)))
    with pytest.raises(ValueError, match="no end_header in its first 65536 bytes"):
        read_sample_file(path, "sample 0")


def test_text_point_clouds_are_bounded_by_points_and_columns(tmp_path, monkeypatch):
    """Found by an adversarial review: 782 KB of gzip held 89 million equal points (3
    minutes to read, then 12 GB in the eigen stage), and 4,096 lines of 32,000 numbers
    took 1.8 GB to parse: the bytes limit bounded neither."""
    from sklearn_meshph.pointcloud import reading

    assert reading.MAX_POINTS == 1 << 24 and reading.MAX_COLUMNS == 64
    wide = tmp_path / "wide.xyz.gz"
    wide.write_bytes(gzip.compress(b"1 " * 100 + b"\n" + b"1 " * 100 + b"\n"))
    with pytest.raises(ValueError, match=r"line 1 holds 100 numbers, more than MAX_COLUMNS"):
        reading.read_point_cloud_file(wide, "sample 3")
    many = tmp_path / "many.xyz.gz"
    many.write_bytes(gzip.compress(b"0 0 0\n" * 3000))
    monkeypatch.setattr(reading, "MAX_POINTS", 2000)
    with pytest.raises(ValueError, match=r"sample 3: .* more than MAX_POINTS \(2000\) points"):
        reading.read_point_cloud_file(many, "sample 3")
    monkeypatch.setattr(reading, "MAX_POINTS", 3000)
    assert reading.read_point_cloud_file(many).shape == (3000, 3)


def test_text_point_cloud_names_what_is_not_a_regular_file(tmp_path):
    from sklearn_meshph.pointcloud.reading import read_point_cloud_file

    (tmp_path / "folder.xyz").mkdir()
    with pytest.raises(ValueError, match=r"folder\.xyz' is not a regular file"):
        read_point_cloud_file(tmp_path / "folder.xyz")
    with pytest.raises(ValueError, match=r"absent\.xyz' does not exist"):
        read_point_cloud_file(tmp_path / "absent.xyz")


def test_text_point_cloud_that_changes_between_the_passes_is_refused(tmp_path, monkeypatch):
    from sklearn_meshph.pointcloud import reading

    path = tmp_path / "scan.xyz"
    path.write_text("".join(f"{k} {k % 7} {k % 3}\n" for k in range(500)))
    original, calls = reading._data_lines, []

    def shrinking(*args):  # the second pass finds a shorter file
        calls.append(1)
        if len(calls) == 2:
            path.write_text("".join(f"{k} 0 0\n" for k in range(100)))
        return original(*args)

    monkeypatch.setattr(reading, "_data_lines", shrinking)
    with pytest.raises(ValueError, match=r"changed while it was read \(500 points counted"):
        reading.read_point_cloud_file(path)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_files_a_mesh_names_beside_it_are_never_read(tmp_path):
    # An OBJ's mtllib naming a FIFO hung trimesh, which followed it from the path.
    os.mkfifo(tmp_path / "trap.mtl")
    evil = tmp_path / "evil.obj"
    evil.write_text("mtllib trap.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\n")
    code = (
        "from sklearn_meshph.mesh.reading import read_mesh_file; "
        f"print(len(read_mesh_file({str(evil)!r}).faces))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=120)
    assert done.stdout.split() == [b"2"], done.stderr.decode()[-2000:]


def test_what_is_not_a_mesh_file_or_folder_is_named(tmp_path):
    (tmp_path / "folder.off").mkdir()
    with pytest.raises(ValueError, match=r"folder\.off' is a directory"):
        read_mesh_file(tmp_path / "folder.off")
    if hasattr(os, "mkfifo"):
        os.mkfifo(tmp_path / "pipe.off")
        with pytest.raises(ValueError, match=r"pipe\.off' is not a regular file"):
            read_mesh_file(tmp_path / "pipe.off")
    (tmp_path / "plain.txt").write_text("not a folder")
    with pytest.raises(ValueError, match=r"plain\.txt' is not a folder"):
        load_mesh_folder(tmp_path / "plain.txt")


OFF_VARIANTS = {
    "counts on the keyword's line": "OFF 4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 3\n",
    "comments and blank lines": (
        "# made by hand\nOFF\n\n# counts\n4 2 0\n0 0 0 # origin\n1 0 0\n\n0 1 0\n0 0 1\n"
        "3 0 1 2\n# the second face\n3 0 1 3\n"
    ),
    "colours (COFF) and face colours": (
        "COFF\n4 2 0\n0 0 0 1 0 0 1\n1 0 0 1 0 0 1\n0 1 0 1 0 0 1\n0 0 1 1 0 0 1\n"
        "3 0 1 2 255 0 0\n3 0 1 3 0 255 0\n"
    ),
    "a quad": "OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n",
    "tabs and CRLF": "OFF\r\n4\t2\t0\r\n0 0 0\r\n1 0 0\r\n0 1 0\r\n0 0 1\r\n3 0 1 2\r\n3\t0 1 3",
}


@pytest.mark.parametrize("name", sorted(OFF_VARIANTS))
def test_off_files_read_as_trimesh_reads_them(tmp_path, name):
    """The OFF reader is ours (trimesh's took up to 40 bytes of memory per byte of
    file): the same vertices and triangles as trimesh's on what both read."""
    path = tmp_path / "a.off"
    path.write_bytes(OFF_VARIANTS[name].encode())
    ours = read_mesh_file(path)
    theirs = trimesh.load(path, process=False, force="mesh")
    np.testing.assert_array_equal(ours.vertices, theirs.vertices)
    # The same oriented triangles; trimesh groups triangles before quads and starts a
    # quad's second triangle elsewhere, ours keep the file's order as fans.
    assert _oriented(ours.faces) == _oriented(theirs.faces)
    if name != "a quad":
        np.testing.assert_array_equal(ours.faces, theirs.faces)


def _oriented(faces):
    """Triangles as a sorted list, each rotated to start at its smallest corner."""
    return sorted(tuple(np.roll(f, -int(np.argmin(f)))) for f in np.asarray(faces))


def test_a_pentagon_is_cut_into_a_fan(tmp_path):
    path = tmp_path / "a.off"
    path.write_text("NOFF\n5 1 0\n" + "0 0 0 0 0 1\n" * 5 + "5 4 3 2 1 0\n")
    np.testing.assert_array_equal(read_mesh_file(path).faces, [[4, 3, 2], [4, 2, 1], [4, 1, 0]])


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n",
            r"the file ends at line 7, after 1 of the 2 faces its header declares \(is it",
        ),
        (
            "OFF\n4 2 0\n0 0 0\n1 0 0\n" + "# padding\n" * 9,
            r"the file ends at line 13, after 2 of the 4 vertices",
        ),
        ("OFF\n4\n", r"line 2: the header must give the numbers of vertices and faces"),
        ("OFF\n-1 2 0\n", r"negative counts"),
        ("OFF\n3 1 0\n0 0 0\n1 0\n0 1 0\n3 0 1 2\n", r"line 4: vertex 1 has 2 coordinates, not 3"),
        (
            "OFF\n3 1 0\n0 0 0\n1 0 x\n0 1 0\n3 0 1 2\n",
            r"vertex 1 holds a value that is not a number of that kind: '1 0 x'",
        ),
        ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", r"face 0 uses vertex 3, outside 0\.\.2"),
        (
            "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n4 0 1 -1 2\n",
            r"face 1 uses vertex -1, outside",
        ),
        (
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n",
            r"face 0 declares 2 corners; a face has 3 to 65536",
        ),
        ("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n", r"face 0 declares 4 corners and lists 3"),
        (
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n99999999999999999999999 0 1 2\n",
            r"face 0 does not start with its number of corners|declares",
        ),
        (
            "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2.5\n",
            r"face 0 holds a value that is not a number of that kind",
        ),
        ("OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n", r"it contains no triangles"),
        ("# only a comment\n\n", r"no OFF keyword"),
        ("OFFX\n3 1 0\n", r"starts with 'OFFX', not the keyword OFF"),
        (
            "OFF\n9999 9999 0\n0 0 0\n",
            r"declares 9999 vertices and 9999 faces, more than the file's 22 bytes can hold",
        ),
    ],
)
def test_a_malformed_or_cut_off_file_names_its_line(tmp_path, text, message):
    path = tmp_path / "bad.off"
    path.write_text(text)
    with pytest.raises(
        ValueError, match=r"^sample 4: mesh file .*bad\.off.* is not a valid \.off mesh"
    ) as info:
        read_mesh_file(path, "sample 4")
    assert "\n" not in str(info.value)
    assert info.match(message)


def test_hostile_off_content_takes_the_memory_of_the_mesh(tmp_path):
    """One-digit values took trimesh's reader about 40 bytes per byte of file (a 218 KB
    .off.gz peaked at 5.6 GB); ours holds the arrays it returns and a block of lines."""
    n = 500_000
    text = b"OFF\n%d %d 0\n" % (n, n) + b"0 0 0\n" * n + b"3 0 0 0\n" * n
    path = tmp_path / "dense.off.gz"
    path.write_bytes(gzip.compress(text))
    mesh, peak = traced_peak(lambda: read_mesh_file(path, allow_points=True))
    assert mesh.faces.shape == (n, 3)
    arrays = mesh.vertices.nbytes + mesh.faces.nbytes  # 3.4 times the text here
    # The content and one copy, the arrays, a block of lines (trimesh's: 40 x the text).
    assert peak < 2 * len(text) + 1.2 * arrays + 10 * 2**20


def test_gigabytes_of_blank_lines_are_refused_at_once(tmp_path):
    path = tmp_path / "blank.off"
    path.write_bytes(b"OFF\n3 1 0\n" + b"\n" * 2_000_000 + b"0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    with pytest.raises(ValueError, match=r"holds 2000006 lines for the 3 vertices and 1 faces"):
        read_mesh_file(path)


@pytest.mark.parametrize("kind", ["obj", "ply"])
def test_a_text_mesh_with_a_line_beyond_the_limit_is_refused_before_parsing(tmp_path, kind):
    """One long line passed the value and line counts, and trimesh copied it several
    times (a 291 KB .obj.gz of a 300 MB line of spaces took 890 MB)."""
    mesh = trimesh.creation.icosphere(1)
    if kind == "obj":
        content = b"# " + b" " * 30_000_000 + b"\n" + mesh.export(file_type="obj").encode()
    else:
        ply = mesh.export(file_type="ply", encoding="ascii")
        # In the body (in the header, the header's own 64 KiB limit refuses it first).
        head, body = ply.split(b"end_header\n", 1)
        content = head + b"end_header\n" + body.replace(b"\n", b" " * 30_000_000 + b"\n", 1)
    path = tmp_path / f"long.{kind}.gz"
    path.write_bytes(gzip.compress(content))
    refused = r"has a line longer than \d+ bytes \(MAX_TEXT_LINE\)"
    _, peak = traced_peak(lambda: read_mesh_file(path), refused)
    assert peak < 1.5 * len(content) + 32 * 2**20


def test_text_meshes_beyond_the_token_limit_are_refused_before_parsing(tmp_path, monkeypatch):
    mesh = trimesh.creation.icosphere(1)
    obj = write(tmp_path / "a.obj", mesh)
    ply_text = tmp_path / "text.ply"
    ply_text.write_bytes(mesh.export(file_type="ply", encoding="ascii"))
    ply_binary = write(tmp_path / "binary.ply", mesh)
    stl_text = tmp_path / "text.stl"
    stl_text.write_bytes(mesh.export(file_type="stl_ascii").encode())
    stl_binary = write(tmp_path / "binary.stl", mesh)
    assert reading.count_tokens(obj.read_bytes()) == len(obj.read_bytes().split())
    monkeypatch.setattr(reading, "MAX_TEXT_TOKENS", 200)
    for path in (obj, ply_text, stl_text):
        with pytest.raises(
            ValueError, match=r"holds \d+ values as text, more than MAX_TEXT_TOKENS \(200\)"
        ):
            read_mesh_file(path)
    for path in (ply_binary, stl_binary):  # binary content is not parsed as text
        assert len(read_mesh_file(path).faces) == len(mesh.faces)


@pytest.mark.parametrize("encoding", ["ascii", "binary_little_endian"])
def test_a_ply_cut_short_is_refused(tmp_path, encoding):
    mesh = trimesh.creation.icosphere(2)
    data = mesh.export(file_type="ply", encoding=encoding)
    path = tmp_path / "cut.ply"
    path.write_bytes(data[: int(len(data) * 0.95)])
    with pytest.raises(ValueError, match=r"cut\.ply.* is not a valid \.ply mesh"):
        read_mesh_file(path)


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (  # one zero-padded value of 40 KB: a block as wide as it took 3.7 GB
            b"OFF\n3 1 0\n" + b"0" * 40000 + b"1 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
            r"vertex 0 holds a value of 40001 characters, more than 64",
        ),
        (
            b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n5 0 1 2 0 " + b"0" * 100 + b"1\n",
            r"face 0 holds a value of 101 characters",
        ),
        (  # 600 MB of spaces passed the bytes check, then 2.7 GB were allocated
            b"OFF\n12000000 0 0\n" + (b" " * 999 + b"\n") * 60_000,
            r"declares 12000000 vertices and 0 faces, and 60001 lines follow it",
        ),
        (  # one line of spaces before the counts: read whole into a copy of itself
            b"OFF\n" + b" " * 60_000_000 + b"\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
            r"line 2: a line longer than \d+ bytes \(MAX_LINE_LENGTH\)",
        ),
        (  # the same with \r\n line ends: they were replaced in a copy of the file first
            b"OFF\r\n" + b" " * 60_000_000 + b"\r\n3 1 0\r\n0 0 0\r\n",
            r"line 2: a line longer than \d+ bytes \(MAX_LINE_LENGTH\)",
        ),
        (  # ... and with lone \r (and a byte order mark, which was sliced off: a copy)
            b"\xef\xbb\xbfOFF\r" + b" " * 60_000_000 + b"\r3 1 0\r0 0 0\r",
            r"line 2: a line longer than \d+ bytes \(MAX_LINE_LENGTH\)",
        ),
        (  # comments before the keyword were read one by one, before any check
            b"#\n" * 1_000_000 + b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
            r"line 4097: 4097 of its first 4097 lines are blank or comments",
        ),
    ],
)
def test_hostile_off_files_are_refused_before_they_cost(tmp_path, content, message):
    path = tmp_path / "hostile.off.gz"
    path.write_bytes(gzip.compress(content))
    start = time.perf_counter()
    _, peak = traced_peak(lambda: read_mesh_file(path), message)
    # The decompressed content, read in place (a copy would be 2x: the old reader's)
    assert peak < 1.3 * len(content) + 32 * 2**20
    assert time.perf_counter() - start < 20


@pytest.mark.parametrize("declared", [301, 500, 10**12])
def test_a_ply_of_points_cut_short_is_refused_like_a_mesh(tmp_path, declared):
    """Found by an adversarial review: an ASCII PLY of vertices only whose header declares
    more vertices than it holds was read as the points it holds, without a word."""
    points = np.random.default_rng(0).normal(size=(300, 3))
    header = (
        f"ply\nformat ascii 1.0\nelement vertex {declared}\nproperty float x\n"
        "property float y\nproperty float z\nend_header\n"
    )
    path = tmp_path / "short.ply"
    path.write_text(header + "".join(f"{x} {y} {z}\n" for x, y, z in points))
    held = ", more than MAX_PLY_ROWS" if declared > 1 << 24 else " and it holds 300"
    with pytest.raises(ValueError, match=rf"short.ply.*declares {declared} vertex rows{held}"):
        read_mesh_file(path, allow_points=True)
    path.write_text(
        header.replace(str(declared), "300") + path.read_text().split("end_header\n")[1]
    )
    assert read_mesh_file(path, allow_points=True).vertices.shape == (300, 3)


def test_off_line_ends_and_byte_order_mark_as_trimesh_reads_them(tmp_path):
    """A lone \\r ends a line for trimesh (and Python): a file of them was refused as
    "cut short", and a stray \\r inside a vertex line made ours read other vertices."""
    expected = read_mesh_file(write(tmp_path / "a.off", trimesh.creation.icosphere(1)))
    text = (tmp_path / "a.off").read_bytes()
    for name, variant in {
        "mac.off": text.replace(b"\n", b"\r"),
        "bom.off": b"\xef\xbb\xbf" + text,
        "mixed.off": text.replace(b"\n", b"\r\n", 5).replace(b"\n", b"\r", 3),
    }.items():
        (tmp_path / name).write_bytes(variant)
        mesh = read_mesh_file(tmp_path / name)
        np.testing.assert_array_equal(mesh.vertices, expected.vertices)
        np.testing.assert_array_equal(mesh.faces, expected.faces)


def test_the_text_bound_sees_what_trimesh_parses(tmp_path, monkeypatch):
    """Found by an adversarial review: trimesh takes a PLY for ASCII when its second line
    holds "ascii" anywhere (two spaces, a tab, the word alone, after 512 bytes), blank
    lines cost it hundreds of bytes each, and Unicode line ends and spaces split values
    that a count of ASCII whitespace missed."""
    mesh = trimesh.creation.icosphere(1)
    text = mesh.export(file_type="ply", encoding="ascii")
    header_end = text.index(b"end_header\n") + len(b"end_header\n")
    header, body = text[:header_end], text[header_end:]
    variants = {
        "two spaces": header.replace(b"format ascii", b"format  ascii"),
        "tab": header.replace(b"format ascii", b"format\tascii"),
        "alone": header.replace(b"format ascii 1.0", b"ascii"),
        "far": header.replace(b"ply\n", b"ply" + b" " * 600 + b"\n", 1),
    }
    monkeypatch.setattr(reading, "MAX_TEXT_TOKENS", 200)
    for name, variant in variants.items():
        path = tmp_path / f"{name.replace(' ', '_')}.ply"
        path.write_bytes(variant + body)
        assert len(trimesh.load(path, process=False, force="mesh").faces) == len(mesh.faces)
        with pytest.raises(ValueError, match=r"values as text, more than MAX_TEXT_TOKENS"):
            read_mesh_file(path)
    monkeypatch.setattr(reading, "MAX_TEXT_TOKENS", 16 * 1024**2)
    monkeypatch.setattr(reading, "MAX_TEXT_LINES", 10_000)
    blank = tmp_path / "blank.ply"
    blank.write_bytes(text + b"\n" * 20_000)
    with pytest.raises(ValueError, match=r"20\d\d\d lines as text, more than MAX_TEXT_LINES"):
        read_mesh_file(blank)
    separated = "v 0 0 0\n" + "".join("v 1\u20282\u2028" for _ in range(6000))
    tokens, lines = reading.count_text(separated.encode())
    assert tokens >= 18_004 and lines >= 12_001  # what str.split and splitlines find
    assert reading.count_text("v 1\u00a02\u00a03".encode())[0] == 4  # no-break spaces


@pytest.mark.parametrize("scan", [7, 1 << 20])
def test_the_long_line_scan_counts_each_line_without_its_end(monkeypatch, scan):
    """A line of exactly the limit passes wherever it is (the scan counted the previous
    line's end in every line after the first); one byte more is found at its start."""
    from sklearn_meshph.mesh import text

    monkeypatch.setattr(text, "_SCAN", scan)  # lines across blocks, and within one
    limit = 10
    for content, expected in [
        (b"a" * 10 + b"\n" + b"b" * 10 + b"\n" + b"c" * 10, None),
        (b"a" * 10 + b"\r\n" + b"b" * 10 + b"\r" + b"c" * 10, None),
        (b"a" * 10 + b"\n" + b"b" * 11 + b"\n", 11),
        (b"a\r\n" + b"c" * 11, 3),
        (b"c" * 11, 0),
    ]:
        assert text.long_line_offset(content, limit) == expected, content
