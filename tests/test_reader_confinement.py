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
import contextlib
import json
import os
import signal
import struct
from pathlib import Path

import numpy as np
import pytest

from mpeg4fba.formats.errors import FormatError
from mpeg4fba.formats.morph_targets import read_morph_targets

pytest.importorskip("pygltflib")

_TRIANGLE = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype="<f4")
_BLOB = _TRIANGLE.tobytes()          # 36 bytes


@contextlib.contextmanager
def _deadline(seconds: int = 30):
    """Fail instead of hanging when a read never ends (e.g. ``/dev/zero``, a FIFO)."""
    def ring(signum, frame):
        raise TimeoutError(f"still reading after {seconds} s")
    old = signal.signal(signal.SIGALRM, ring)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


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
    with _deadline():
        base, targets = read_morph_targets(path)
    assert targets == []
    return base["Tri"]


def _refused(path: Path, uri: str, *words: str) -> FormatError:
    with _deadline(), pytest.raises(FormatError) as info:
        read_morph_targets(path)
    e = info.value
    assert e.path == str(path)
    assert "buffers[0]" in e.message and repr(uri) in e.message, e.message
    for w in words:
        assert w in e.message, e.message
    return e


# -- what still reads -------------------------------------------------------------------------

def test_relative_bin_reads(tmp_path):
    (tmp_path / "tri.bin").write_bytes(_BLOB)
    np.testing.assert_array_equal(_read(_write_gltf(tmp_path / "tri.gltf", "tri.bin")), _TRIANGLE)


def test_relative_bin_in_a_subfolder_and_percent_encoded_name_reads(tmp_path):
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "my tri.bin").write_bytes(_BLOB)
    for uri in ["data/my%20tri.bin", "./data/my%20tri.bin", "data%2Fmy%20tri.bin"]:
        np.testing.assert_array_equal(_read(_write_gltf(tmp_path / "tri.gltf", uri)), _TRIANGLE)


def test_symlink_inside_the_folder_reads(tmp_path):
    (tmp_path / "real.bin").write_bytes(_BLOB)
    (tmp_path / "link.bin").symlink_to(tmp_path / "real.bin")
    np.testing.assert_array_equal(_read(_write_gltf(tmp_path / "tri.gltf", "link.bin")), _TRIANGLE)


def test_data_uri_and_glb_chunk_read(tmp_path):
    uri = "data:application/octet-stream;base64," + base64.b64encode(_BLOB).decode()
    np.testing.assert_array_equal(_read(_write_gltf(tmp_path / "tri.gltf", uri)), _TRIANGLE)
    np.testing.assert_array_equal(_read(_write_glb(tmp_path / "tri.glb", None, _BLOB)), _TRIANGLE)


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


def test_symlink_leading_out_is_refused(secret):
    face = secret.parent / "face"
    (face / "link.bin").symlink_to(secret)
    (face / "zero.bin").symlink_to("/dev/zero")
    (face / "up").symlink_to(secret.parent)      # a folder link: the file under it is outside
    for uri in ["link.bin", "zero.bin", "up/secret.bin"]:
        _refused(_write_gltf(face / "tri.gltf", uri), uri, "outside the folder")


def test_fifo_and_folder_are_refused(tmp_path):
    os.mkfifo(tmp_path / "pipe.bin")       # opening it for reading would wait for a writer
    (tmp_path / "dir.bin").mkdir()
    for uri in ["pipe.bin", "dir.bin"]:
        _refused(_write_gltf(tmp_path / "tri.gltf", uri), uri, "not a regular file")


def test_file_shorter_than_byte_length_is_refused(tmp_path):
    (tmp_path / "tri.bin").write_bytes(_BLOB)
    for declared in [len(_BLOB) + 4, 1 << 50]:
        path = _write_gltf(tmp_path / "tri.gltf", "tri.bin", byte_length=declared)
        _refused(path, "tri.bin", f"has {len(_BLOB)} bytes", f"byteLength {declared}")


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
