"""Heads as scanners write them: PLY, STL and OFF read through meshio
(mpeg4fba.formats.scans), found and cloned like any mesh file; bad files get clear errors."""
from __future__ import annotations

import sys

import numpy as np
import pytest
from click.testing import CliRunner

from mpeg4fba.cli import main
from mpeg4fba.formats.errors import FormatError
from mpeg4fba.formats.face_files import read_face
from mpeg4fba.formats.fpjson import read_feature_points_json
from mpeg4fba.formats.scans import read_scan
from mpeg4fba.models import reference_head

meshio = pytest.importorskip("meshio", reason="meshio (the [scans] extra) is not installed")


@pytest.fixture(scope="module")
def head():
    return reference_head(resolution=0.5, face_width=1.05, nose=0.95, seed=8)


@pytest.fixture(scope="module")
def files(tmp_path_factory, head):
    d = tmp_path_factory.mktemp("scans")
    skin = head.meshes["Skin"]
    V, T = head.world_vertices("Skin"), skin.triangles
    meshio.write(d / "head.stl", meshio.Mesh(V, [("triangle", T)]), binary=True)
    meshio.write(d / "head.ply", meshio.Mesh(V, [("triangle", T)]), binary=True)
    meshio.write(d / "ascii.ply", meshio.Mesh(V, [("triangle", T)]), binary=False)
    quads = np.array([[0, 1, 2, 3]])
    meshio.write(d / "quad.ply", meshio.Mesh(np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0.0]]),
                                             [("quad", quads)]), binary=False)
    meshio.write(d / "cloud.ply", meshio.Mesh(V[:50], []), binary=False)
    (d / "garbage.ply").write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 99999999\n"
                                    b"property float x\nend_header\n\x00\x01")
    (d / "short.stl").write_bytes((d / "head.stl").read_bytes()[:300])
    return d


def test_each_format_reads_the_surface(files, head):
    V0 = head.world_vertices("Skin")
    for name in ("head.stl", "head.ply", "ascii.ply"):
        V, T = read_scan(files / name)
        assert len(T) == len(head.meshes["Skin"].triangles), name
        # (an STL keeps every corner: its vertices are the head's, repeated)
        assert np.abs(V[T].reshape(-1, 3) - V0[head.meshes["Skin"].triangles].reshape(-1, 3)).max() < 1e-5
    V, T = read_scan(files / "quad.ply")
    assert T.tolist() == [[0, 1, 2], [0, 2, 3]]
    face = read_face(files / "head.stl")
    assert list(face.meshes) == ["head"] and len(face.points) == 0


@pytest.mark.parametrize("name,words", [("cloud.ply", "no triangles"), ("garbage.ply", "not a readable PLY"),
                                        ("short.stl", "STL")])
def test_bad_scans_are_clear_errors(files, name, words):
    with pytest.raises(FormatError, match=words) as e:
        read_scan(files / name)
    assert name in str(e.value)
    r = CliRunner().invoke(main, ["points", str(files / name), "-o", str(files / "x.json")])
    assert r.exit_code != 0 and name in r.output and "Traceback" not in r.output


def test_without_meshio_the_error_says_what_to_install(files, monkeypatch):
    monkeypatch.setitem(sys.modules, "meshio", None)
    with pytest.raises(FormatError, match=r"mpeg4fba\[scans\]"):
        read_scan(files / "head.ply")


def test_points_on_an_stl_and_a_clone_of_a_ply(files, head):
    r = CliRunner().invoke(main, ["points", str(files / "head.stl"), "-o", str(files / "head.json")])
    assert r.exit_code == 0, r.output
    found, _ = read_feature_points_json(files / "head.json")
    es = float(np.linalg.norm(head.points["3.5"] - head.points["3.6"]))
    for k in ("9.3", "2.2", "8.3", "8.4", "3.8", "3.11"):
        assert np.linalg.norm(found[k] - head.points[k]) < 0.1 * es, k
    r = CliRunner().invoke(main, ["clone", str(files / "head.ply"), "-o", str(files / "out.wrl")])
    assert r.exit_code == 0, r.output
    out = read_face(files / "out.wrl")
    assert len(out.fat.faps) > 40
