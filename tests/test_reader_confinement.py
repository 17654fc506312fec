"""Readers stay inside their bounds (issue 17).

* A glTF face never makes us read outside its own folder: a buffer URI is a base64
  ``data:`` URI or a relative path to a regular file in the folder, read up to its
  ``byteLength``; absolute paths, ``..``, percent-encoded forms of them, other schemes,
  symbolic links leading out, devices and FIFOs are a FormatError naming the file, the
  JSON path and the URI.
* A gzipped VRML file is inflated incrementally under an absolute cap and a ratio cap
  (a decompression bomb stops with a VRMLError saying the limit and how to raise it);
  the keyword arguments and the CLI's global options raise them.
"""
from __future__ import annotations

import base64
import gzip
import importlib.util
import json
import os
import struct
import tracemalloc
import zlib
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from _guards import alarm

from mpeg4fba import vrml
from mpeg4fba.cli import main
from mpeg4fba.formats.errors import FormatError
from mpeg4fba.formats.morph_targets import read_morph_targets
from mpeg4fba.vrml import inflate

needs_gltf = pytest.mark.skipif(importlib.util.find_spec("pygltflib") is None,
                                reason="reading glTF needs pygltflib")

_TRIANGLE = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype="<f4")
_BLOB = _TRIANGLE.tobytes()          # 36 bytes


def _doc(uri, byte_length: int = len(_BLOB), images=()) -> dict:
    """A one-triangle glTF whose buffer is ``uri`` (None: the GLB chunk)."""
    buffer = {"byteLength": byte_length}
    if uri is not None:
        buffer["uri"] = uri
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
           "nodes": [{"name": "Tri", "mesh": 0}],
           "meshes": [{"name": "Tri", "primitives": [{"attributes": {"POSITION": 0}}]}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}],
           "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(_BLOB)}],
           "buffers": [buffer]}
    if images:
        doc["images"] = [{"uri": u} for u in images]
    return doc


def _write_gltf(path: Path, uri, **kw) -> Path:
    path.write_text(json.dumps(_doc(uri, **kw)))
    return path


def _write_glb(path: Path, uri, blob: bytes = b"", **kw) -> Path:
    text = json.dumps(_doc(uri, **kw)).encode()
    text += b" " * (-len(text) % 4)
    chunks = struct.pack("<I4s", len(text), b"JSON") + text
    if blob:
        blob += bytes(-len(blob) % 4)
        chunks += struct.pack("<I4s", len(blob), b"BIN\0") + blob
    path.write_bytes(struct.pack("<4sII", b"glTF", 2, 12 + len(chunks)) + chunks)
    return path


def _read(path: Path) -> np.ndarray:
    with alarm(30, "reading the file"):
        base, targets = read_morph_targets(path)
    assert targets == []
    return base["Tri"]


def _refused(path: Path, uri: str, *words: str) -> FormatError:
    with alarm(30, "reading the file"), pytest.raises(FormatError) as info:
        read_morph_targets(path)
    e = info.value
    assert e.path == str(path)
    assert "buffers[0]" in e.message and repr(uri) in e.message, e.message
    for w in words:
        assert w in e.message, e.message
    return e


# -- what still reads -------------------------------------------------------------------------

@needs_gltf
def test_relative_bin_reads(tmp_path):
    (tmp_path / "tri.bin").write_bytes(_BLOB)
    np.testing.assert_array_equal(_read(_write_gltf(tmp_path / "tri.gltf", "tri.bin")), _TRIANGLE)


@needs_gltf
def test_relative_bin_in_a_subfolder_and_percent_encoded_name_reads(tmp_path):
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "my tri.bin").write_bytes(_BLOB)
    for uri in ["data/my%20tri.bin", "./data/my%20tri.bin", "data%2Fmy%20tri.bin"]:
        np.testing.assert_array_equal(_read(_write_gltf(tmp_path / "tri.gltf", uri)), _TRIANGLE)


@needs_gltf
def test_symlink_inside_the_folder_reads(tmp_path):
    (tmp_path / "real.bin").write_bytes(_BLOB)
    (tmp_path / "link.bin").symlink_to(tmp_path / "real.bin")
    np.testing.assert_array_equal(_read(_write_gltf(tmp_path / "tri.gltf", "link.bin")), _TRIANGLE)


@needs_gltf
def test_data_uri_and_glb_chunk_read(tmp_path):
    uri = "data:application/octet-stream;base64," + base64.b64encode(_BLOB).decode()
    np.testing.assert_array_equal(_read(_write_gltf(tmp_path / "tri.gltf", uri)), _TRIANGLE)
    np.testing.assert_array_equal(_read(_write_glb(tmp_path / "tri.glb", None, _BLOB)), _TRIANGLE)


@needs_gltf
def test_only_byte_length_bytes_are_read(tmp_path):
    # a sparse file far larger than memory: reading it all would never finish
    big = tmp_path / "big.bin"
    with open(big, "wb") as f:
        f.write(_BLOB)
        try:
            f.truncate(1 << 40)
        except OSError:
            pytest.skip("the file system has no sparse files of 1 TiB")
    np.testing.assert_array_equal(_read(_write_gltf(tmp_path / "tri.gltf", "big.bin")), _TRIANGLE)


@needs_gltf
def test_pygltflib_opens_no_buffer_or_image(tmp_path, monkeypatch):
    import pygltflib

    def never(*args, **kwargs):
        raise AssertionError("pygltflib was asked to open a file a URI names")
    for name in ["load_file_uri", "identify_uri", "get_data_from_buffer_uri",
                 "convert_buffers", "convert_images"]:
        monkeypatch.setattr(pygltflib.GLTF2, name, never, raising=False)
    (tmp_path / "tri.bin").write_bytes(_BLOB)
    # an image is never opened, whatever it names
    path = _write_gltf(tmp_path / "tri.gltf", "tri.bin", images=["/dev/zero", "../x.png"])
    np.testing.assert_array_equal(_read(path), _TRIANGLE)


# -- what is refused --------------------------------------------------------------------------

@pytest.fixture
def secret(tmp_path) -> Path:
    """A file beside the face's folder (tmp_path/face/), which the face must not reach."""
    (tmp_path / "secret.bin").write_bytes(_BLOB)
    (tmp_path / "face").mkdir()
    return tmp_path / "secret.bin"


@needs_gltf
@pytest.mark.parametrize("make_uri, why", [
    (lambda s: str(s), "absolute path"),
    (lambda s: "../secret.bin", "'..'"),
    (lambda s: "sub/../../secret.bin", "'..'"),
    (lambda s: "..%2Fsecret.bin", "'..'"),
    (lambda s: "%2E%2E/secret.bin", "'..'"),
    (lambda s: "..%5Csecret.bin", "'..'"),
    (lambda s: str(s).replace("/", "%2F"), "absolute path"),
    (lambda s: "%2Fetc%2Fpasswd", "absolute path"),
    (lambda s: "/etc/passwd", "absolute path"),
    (lambda s: "file://" + str(s), "'file:'"),
    (lambda s: "http://example.invalid/secret.bin", "'http:'"),
    (lambda s: "/dev/zero", "absolute path"),
], ids=["absolute", "dotdot", "nested-dotdot", "encoded-slash", "encoded-dots", "backslash",
        "encoded-absolute", "encoded-passwd", "passwd", "file-scheme", "http", "dev-zero"])
@pytest.mark.parametrize("kind", ["gltf", "glb"])
def test_uri_leading_out_is_refused(secret, make_uri, why, kind):
    uri = make_uri(secret)
    face = secret.parent / "face"
    path = _write_gltf(face / "tri.gltf", uri) if kind == "gltf" else \
        _write_glb(face / "tri.glb", uri)
    e = _refused(path, uri, why, "relative path")
    assert "buffers[0].uri" in e.message


@needs_gltf
def test_symlink_leading_out_is_refused(secret):
    face = secret.parent / "face"
    (face / "link.bin").symlink_to(secret)
    (face / "zero.bin").symlink_to("/dev/zero")
    (face / "up").symlink_to(secret.parent)      # a folder link: the file under it is outside
    for uri in ["link.bin", "zero.bin", "up/secret.bin"]:
        _refused(_write_gltf(face / "tri.gltf", uri), uri, "outside the folder")


@needs_gltf
def test_fifo_and_folder_are_refused(tmp_path):
    os.mkfifo(tmp_path / "pipe.bin")       # opening it for reading would wait for a writer
    (tmp_path / "dir.bin").mkdir()
    for uri in ["pipe.bin", "dir.bin"]:
        _refused(_write_gltf(tmp_path / "tri.gltf", uri), uri, "not a regular file")


@needs_gltf
def test_file_shorter_than_byte_length_is_refused(tmp_path):
    (tmp_path / "tri.bin").write_bytes(_BLOB)
    for declared in [len(_BLOB) + 4, 1 << 50]:
        path = _write_gltf(tmp_path / "tri.gltf", "tri.bin", byte_length=declared)
        _refused(path, "tri.bin", f"has {len(_BLOB)} bytes", f"byteLength {declared}")


@needs_gltf
def test_bad_byte_length_and_data_uri_are_refused(tmp_path):
    (tmp_path / "tri.bin").write_bytes(_BLOB)
    doc = _doc("tri.bin")
    del doc["buffers"][0]["byteLength"]
    (tmp_path / "tri.gltf").write_text(json.dumps(doc))
    with pytest.raises(FormatError, match=r"buffers\[0\]\.byteLength"):
        read_morph_targets(tmp_path / "tri.gltf")
    short = "data:application/octet-stream;base64," + base64.b64encode(_BLOB[:12]).decode()
    with pytest.raises(FormatError, match=r"buffers\[0\] holds 12 bytes, fewer than"):
        read_morph_targets(_write_gltf(tmp_path / "tri.gltf", short))
    with pytest.raises(FormatError, match=r"only base64"):
        read_morph_targets(_write_gltf(tmp_path / "tri.gltf", "data:text/plain,abc"))


# -- gzip bombs -------------------------------------------------------------------------------

_HEADER = b"#VRML V2.0 utf8\n"


def _gzip_stream(path: Path, head: bytes, filler: bytes, size: int) -> Path:
    """``head`` then ``size`` bytes of ``filler`` repeated, gzipped a MiB at a time
    (a bomb is written without ever holding it inflated)."""
    c = zlib.compressobj(6, zlib.DEFLATED, 16 + zlib.MAX_WBITS)
    block = (filler * ((1 << 20) // len(filler) + 1))[:1 << 20]
    with open(path, "wb") as f:
        f.write(c.compress(head))
        for _ in range(size >> 20):
            f.write(c.compress(block))
        f.write(c.compress(block[:size & ((1 << 20) - 1)]))
        f.write(c.flush())
    return path


def _scene_text(n: int) -> bytes:
    """A real scene of about ``n`` bytes, not very compressible (numbers)."""
    pts = np.random.default_rng(1).normal(size=(max(n // 30, 3), 3))
    body = ", ".join(f"{x:.5f} {y:.5f} {z:.5f}" for x, y, z in pts)
    shape = f"DEF P Shape {{ geometry PointSet {{ coord Coordinate {{ point [ {body} ] }} }} }}\n"
    return _HEADER + shape.encode()


def test_bomb_stops_early_under_the_default_ratio(tmp_path):
    bomb = _gzip_stream(tmp_path / "bomb.wrl.gz", _HEADER, b"\0", 50 << 20)
    assert bomb.stat().st_size < 100 << 10
    tracemalloc.start()
    try:
        with pytest.raises(vrml.VRMLError) as info:
            vrml.load(bomb)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    e = info.value
    assert e.path == str(bomb)
    assert "max_ratio=1000" in e.message and "decompression bomb" in e.message, e.message
    assert "--max-ratio" in e.message
    assert peak < 40 << 20, f"{peak >> 20} MiB held: more than the ratio cap lets through"


def test_bomb_stops_at_the_absolute_cap(tmp_path):
    bomb = _gzip_stream(tmp_path / "bomb.txt", _HEADER, b"\0", 50 << 20)   # magic, not name
    with pytest.raises(vrml.VRMLError) as info:
        vrml.load(bomb, max_inflated=3 << 20, max_ratio=0)
    e = info.value
    assert e.path == str(bomb) and "more than 3.0 MiB" in e.message
    assert "max_inflated=3145728" in e.message and "--max-inflated" in e.message, e.message


def test_ordinary_gzip_still_reads(tmp_path):
    text = _scene_text(600 << 10)            # several input chunks of compressed data
    p = tmp_path / "points.wrl.gz"
    p.write_bytes(gzip.compress(text, mtime=0))
    assert p.stat().st_size > 2 * inflate._IN_CHUNK
    want = vrml.loads(text.decode())
    assert vrml.load(p) == want
    # several members, as `cat a.gz b.gz` makes: read as one stream
    half = len(text) // 2
    p.write_bytes(gzip.compress(text[:half]) + gzip.compress(text[half:]))
    assert vrml.load(p) == want
    # the ratio cap is per compressed byte: a plain file is not limited at all
    (tmp_path / "plain.wrl").write_bytes(text)
    assert vrml.load(tmp_path / "plain.wrl", max_inflated=10) == want


def test_keywords_raise_the_caps(tmp_path, monkeypatch):
    # 2 MiB of spaces in a comment inflates ~1000:1; let the ratio apply from 64 KiB
    monkeypatch.setattr(inflate, "RATIO_FREE", 64 << 10)
    p = _gzip_stream(tmp_path / "spaces.wrl.gz", _HEADER + b"Group { }\n#", b" ", 2 << 20)
    with pytest.raises(vrml.VRMLError, match="max_ratio"):
        vrml.load(p)
    assert vrml.load(p, max_ratio=0).nodes[0].type == "Group"
    assert vrml.load(p, max_ratio=5000).nodes[0].type == "Group"
    with pytest.raises(vrml.VRMLError, match="max_inflated"):
        vrml.load(p, max_ratio=0, max_inflated=1 << 20)
    with vrml.inflate_limits(max_inflated=1 << 20, max_ratio=0):   # a lower default ...
        with pytest.raises(vrml.VRMLError, match="max_inflated"):
            vrml.load(p)
        assert vrml.load(p, max_inflated=4 << 20).nodes[0].type == "Group"   # ... raised
    for bad in [{"max_inflated": 0}, {"max_inflated": 1.5}, {"max_ratio": -1}]:
        with pytest.raises(ValueError):
            vrml.load(p, **bad)


def test_load_face_and_read_face_pass_the_caps_on(tmp_path):
    from mpeg4fba.fba.face import FaceMesh, FaceModel
    from mpeg4fba.formats.face_files import read_face
    from mpeg4fba.formats.wrl_face import load_face, save_face
    n = 40
    grid = np.stack(np.meshgrid(np.arange(n), np.arange(n)), -1).reshape(-1, 2)
    vertices = np.c_[grid, np.zeros(len(grid))] * 0.01
    k = np.arange(n - 1)[:, None] * n + np.arange(n - 1)[None, :]
    tris = np.r_[np.stack([k, k + 1, k + n], -1).reshape(-1, 3),
                 np.stack([k + 1, k + n + 1, k + n], -1).reshape(-1, 3)]
    p = tmp_path / "grid.wrl.gz"
    save_face(FaceModel([FaceMesh("Grid", vertices, tris)]), p)
    assert len(load_face(p).meshes["Grid"].vertices) == n * n
    for read in (load_face, read_face):
        with pytest.raises(vrml.VRMLError, match="max_inflated=1000") as info:
            read(p, max_inflated=1000)
        assert info.value.path == str(p)
    assert len(read_face(p, max_inflated=10 << 20, max_ratio=0).meshes["Grid"].vertices) == n * n


def test_cli_options_set_the_caps(tmp_path, monkeypatch):
    monkeypatch.setattr(inflate, "RATIO_FREE", 64 << 10)
    p = _gzip_stream(tmp_path / "spaces.wrl.gz", _HEADER + b"Group { }\n#", b" ", 2 << 20)
    runner = CliRunner()
    before = inflate._limits.get()
    r = runner.invoke(main, ["info", str(p)])
    assert r.exit_code == 1 and r.output.count("\n") == 1, r.output
    assert r.output.startswith(f"mpeg4fba: error: {p}: gzip data inflates")
    assert "--max-ratio" in r.output
    r = runner.invoke(main, ["--max-ratio", "0", "info", str(p)])
    assert r.exit_code == 0, r.output
    r = runner.invoke(main, ["--max-ratio", "0", "--max-inflated", "1M", "info", str(p)])
    assert r.exit_code == 1 and "max_inflated=1048576" in r.output, r.output
    with vrml.inflate_limits(max_inflated=1 << 20, max_ratio=0):
        assert runner.invoke(main, ["info", str(p)]).exit_code == 1
        r = runner.invoke(main, ["--max-inflated", "4MiB", "info", str(p)])
        assert r.exit_code == 0, r.output
    assert inflate._limits.get() == before            # the options last one command
    out = tmp_path / "out.wrl"
    r = runner.invoke(main, ["convert", str(p), str(out)])
    assert r.exit_code == 1 and not out.exists()      # no half-written output
    r = runner.invoke(main, ["--max-inflated", "lots", "info", str(p)])
    assert r.exit_code == 2 and "--max-inflated" in r.output
