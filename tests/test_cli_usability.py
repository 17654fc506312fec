"""The command line's manners (issue 17): outputs checked before any work and never an
input, clear one-line errors, names for visemes and expressions, real JPEGs, warnings
summed up, .glb files read back by info and validate, the LICENSE."""
from __future__ import annotations

import gzip
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from mpeg4fba.cli import main
from mpeg4fba.cli.common import summarise_warnings
from mpeg4fba.fba.face import FaceMesh, FaceModel
from mpeg4fba.fba.fat import FAT
from mpeg4fba.fba.featurepoints import FeaturePointSet
from mpeg4fba.formats.fap import write_fap
from mpeg4fba.formats.gltf import write_glb
from mpeg4fba.formats.wrl_face import save_face
from mpeg4fba.models import reference_head
from mpeg4fba.models.phrase import demo_stream

REPO = Path(__file__).resolve().parents[1]
SIZE = ("--size", "60x70")


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A small face (.wrl and .glb), a short stream, and a target with skin only."""
    d = tmp_path_factory.mktemp("usability")
    head = reference_head(resolution=0.5)
    save_face(head, d / "face.wrl")
    write_glb(head, d / "face.glb", demo_stream())
    write_fap(demo_stream(), d / "talk.fap")
    other = reference_head(resolution=0.5, face_width=1.1, seed=3)
    skin = other.meshes["Skin"]
    # no eyes, teeth or tongue: the cloner warns about each FAP that moves them
    only_skin = FaceModel([FaceMesh("Skin", other.world_vertices("Skin"), skin.triangles)],
                          points=FeaturePointSet({k: other.points[k] for k in other.points}),
                          fat=FAT(), name="skin_only")
    save_face(only_skin, d / "skin.wrl")
    return d


@pytest.fixture(scope="module")
def skin_clone(files):
    """One clone (several seconds), shared: the reference head onto the skin-only face."""
    out = files / "skin_animated.wrl"
    r = run("clone", files / "skin.wrl", "-o", out)
    assert r.exit_code == 0, r.output + r.stderr
    return r, out


def _unchanged(path: Path, before: bytes) -> bool:
    return path.read_bytes() == before


# -- 1. an output that is an input is refused, before any work --------------------------------

def test_render_refuses_to_overwrite_its_input_also_through_links(files, tmp_path):
    face = tmp_path / "face.wrl"
    face.write_bytes((files / "face.wrl").read_bytes())
    before = face.read_bytes()
    (tmp_path / "sym.wrl").symlink_to(face)
    os.link(face, tmp_path / "hard.wrl")
    for out in (face, tmp_path / "sym.wrl", tmp_path / "hard.wrl"):
        r = run("render", face, "-o", out, *SIZE)
        assert r.exit_code == 2, (out, r.output)
        assert "also an input (FACE)" in r.stderr and "overwrite" in r.stderr
        assert _unchanged(face, before)
    r = run("render", tmp_path / "sym.wrl", "-o", face, *SIZE)       # the link as the input
    assert r.exit_code == 2 and "also an input" in r.stderr and _unchanged(face, before)


def test_render_refuses_a_grid_face_as_output(files, tmp_path):
    other = tmp_path / "other.png"     # an odd name for a face, but it must not be destroyed
    other.write_bytes(b"not really a face")
    r = run("render", files / "face.wrl", "--grid", other, "-o", other, *SIZE)
    assert r.exit_code == 2 and "also an input (--grid)" in r.stderr
    assert other.read_bytes() == b"not really a face"


def test_play_refuses_to_overwrite_its_face_or_stream(files, tmp_path):
    face = tmp_path / "face.wrl"
    face.write_bytes((files / "face.wrl").read_bytes())
    before = face.read_bytes()
    os.link(face, tmp_path / "same.wrl")
    for out in (face, tmp_path / "same.wrl"):
        r = run("play", face, files / "talk.fap", "-o", out)
        assert r.exit_code == 2 and "also an input (FACE)" in r.stderr, r.output
        assert _unchanged(face, before)
    stream = tmp_path / "talk.fap"
    stream.write_bytes((files / "talk.fap").read_bytes())
    r = run("play", face, stream, "-o", stream)
    assert r.exit_code == 2 and "also an input (STREAM)" in r.stderr


def test_clone_refuses_its_target_as_output_at_once(files, tmp_path):
    target = tmp_path / "t.wrl"
    target.write_bytes((files / "skin.wrl").read_bytes())
    before = target.read_bytes()
    os.symlink(target, tmp_path / "link.wrl")
    for out in (target, tmp_path / "link.wrl"):
        r = run("clone", target, "-o", out)
        assert r.exit_code == 2 and "also an input (TARGET)" in r.stderr, r.output
        assert _unchanged(target, before)
    r = run("clone", files / "face.wrl", target, "-o", files / "face.wrl")
    assert r.exit_code == 2 and "also an input (SOURCE)" in r.stderr


def test_convert_refuses_to_rewrite_its_input_in_place(files, tmp_path):
    src = tmp_path / "a.wrl"
    src.write_text("#VRML V2.0 utf8\n# a comment that a rewrite would lose\nGroup {}\n")
    before = src.read_bytes()
    for args in ([src, src], [src, "-o", src]):
        r = run("convert", *args)
        assert r.exit_code == 2 and "also an input (IN)" in r.stderr, r.output
        assert _unchanged(src, before)


# -- 2. every output path checked before any work ---------------------------------------------

def test_clone_checks_its_output_folder_before_reading_anything(tmp_path):
    # the target does not even exist: the output is what is wrong first
    r = run("clone", tmp_path / "no-such-target.wrl", "-o", tmp_path / "no-such-folder" / "o.wrl")
    assert r.exit_code == 2
    assert "the folder" in r.stderr and "no-such-folder does not exist" in r.stderr
    r = run("clone", tmp_path / "no-such-target.wrl", "-o", tmp_path / "o.obj")
    assert r.exit_code == 2 and "a face is written as .wrl" in r.stderr


def test_outputs_that_are_folders_or_unwritable_are_refused(files, tmp_path, monkeypatch):
    (tmp_path / "pic.png").mkdir()
    r = run("render", files / "face.wrl", "-o", tmp_path / "pic.png", *SIZE)
    assert r.exit_code == 2 and "is a folder" in r.stderr
    (tmp_path / "afile").write_text("x")
    r = run("play", "--example", "--demo-stream", "-o", tmp_path / "afile" / "frames")
    assert r.exit_code == 2 and "is a file, not a folder" in r.stderr
    real_access = os.access
    locked = str(tmp_path / "locked")
    os.mkdir(locked)
    # (running as root, chmod would not stop us: pretend the folder is read-only)
    monkeypatch.setattr(os, "access", lambda p, mode, **k: False if os.fspath(p) == locked
                        else real_access(p, mode, **k))
    for args in (["render", files / "face.wrl", "-o", Path(locked) / "x.png", *SIZE],
                 ["clone", files / "skin.wrl", "-o", Path(locked) / "x.wrl"],
                 ["convert", files / "face.wrl", Path(locked) / "x.wrl"],
                 ["demo", Path(locked) / "demo"]):
        r = run(*args)
        assert r.exit_code == 2 and "can't write in the folder" in r.stderr, (args, r.output)
    assert os.listdir(locked) == []


def test_unsupported_extensions_are_refused(files, tmp_path):
    cases = [(["render", files / "face.wrl", "-o", tmp_path / "x.txt", *SIZE], "a picture is written as"),
             (["convert", files / "face.wrl", tmp_path / "x.glb"], "VRML97 is written as"),
             (["play", "--example", "--demo-stream", "-o", tmp_path / "talk.mp4"], "an animation is written as")]
    for args, words in cases:
        r = run(*args)
        assert r.exit_code == 2 and words in r.stderr, (args, r.output)
    assert os.listdir(tmp_path) == []


# -- 3. progress on a terminal, clean output elsewhere, warnings summed up --------------------

def test_clone_output_is_clean_off_a_terminal_and_warnings_come_by_kind(skin_clone):
    r, out = skin_clone
    assert out.exists() and r.stdout.startswith("cloned reference_head onto skin_only")
    lines = r.stderr.splitlines()
    assert lines and all(line.startswith("mpeg4fba: warning: ") for line in lines)  # no bar
    # one line per kind: FAPs 43-47 move the tongue, and there used to be a line each
    # (the cloner now says it once itself; summarise_warnings sums up any repeats)
    tongue = [line for line in lines if "tongue" in line]
    assert len(tongue) == 1 and "43-47" in tongue[0]
    assert len(lines) < 12


def test_summarise_warnings_lists_the_numbers_that_vary():
    messages = [f"the target has no tongue; FAP {k}'s motion of it is not cloned" for k in (1, 2, 3, 14)]
    messages.insert(1, "installed Transform Head at [0.0, -0.058]")
    assert summarise_warnings(messages) == [
        "the target has no tongue; FAP 1-3, 14's motion of it is not cloned (4 warnings like this)",
        "installed Transform Head at [0.0, -0.058]"]
    assert summarise_warnings(["a 1.5 b", "a 2.5 b"]) == ["a 1.5, 2.5 b (2 warnings like this)"]
    # several numbers vary (places in a file): listing each would mix them up
    assert summarise_warnings(["f.wrl:3:5: unknown node", "f.wrl:10:2: unknown node"]) == [
        "f.wrl:3:5: unknown node (and 1 more like this)"]


def test_clone_steps_show_on_a_terminal(tmp_path):
    import pty

    # stderr on a pseudo-terminal: the bar names the step under way (here the first, which
    # fails at once on a missing target; the error still comes as one line)
    parent, child = pty.openpty()
    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, "-m", "mpeg4fba", "clone", str(tmp_path / "missing.wrl"),
                           "-o", str(tmp_path / "out.wrl")],
                          stderr=child, stdout=subprocess.PIPE, env=env, timeout=300)
    os.close(child)
    chunks = []
    while True:
        try:
            data = os.read(parent, 4096)
        except OSError:  # the other end is closed and drained
            break
        if not data:
            break
        chunks.append(data)
    os.close(parent)
    text = b"".join(chunks).decode("utf-8", "replace")
    assert proc.returncode == 1
    assert "mpeg4fba clone" in text and "reading the faces" in text, text
    assert "mpeg4fba: error:" in text and "missing.wrl" in text


# -- 4. error messages -------------------------------------------------------------------------

def test_errors_without_a_file_have_no_string_prefix(tmp_path):
    from mpeg4fba import vrml
    from mpeg4fba.formats.errors import FormatError

    assert str(FormatError("not a feature point file")) == "not a feature point file"
    with pytest.raises(vrml.VRMLError) as e:
        vrml.loads("#VRML V2.0 utf8\nTransform { scael 1 1 1 }")
    assert str(e.value).startswith("line 2, column 13: ") and "<string>" not in str(e.value)
    r = run("render", tmp_path / "face.xyz", "-o", tmp_path / "x.png")
    assert r.exit_code == 1 and "<string>" not in r.stderr
    assert r.stderr.startswith(f"mpeg4fba: error: {tmp_path / 'face.xyz'}: a face is read from")


def test_write_errors_name_the_path_asked_for(tmp_path, monkeypatch):
    import tempfile

    from mpeg4fba._atomic import atomic_write

    (tmp_path / "out.png").mkdir()
    with pytest.raises(OSError) as e:
        atomic_write(tmp_path / "out.png", b"data")
    assert e.value.filename == str(tmp_path / "out.png")

    def refuse(*a, dir=None, **k):
        raise PermissionError(13, "Permission denied", os.path.join(dir, ".mpeg4fba-partial-1-abc-x.wrl"))

    monkeypatch.setattr(tempfile, "mkstemp", refuse)
    with pytest.raises(PermissionError) as e:
        atomic_write(tmp_path / "x.wrl", b"data")
    assert e.value.filename == str(tmp_path / "x.wrl") and ".mpeg4fba-partial-" not in str(e.value)
    assert [p.name for p in tmp_path.iterdir()] == ["out.png"]


def test_render_takes_viseme_and_expression_names(files, tmp_path):
    by_name, by_number = tmp_path / "name.png", tmp_path / "number.png"
    r = run("render", files / "face.wrl", "--viseme", "aa", "--expression", "joy", "-o", by_name, *SIZE)
    assert r.exit_code == 0, r.output + r.stderr
    r = run("render", files / "face.wrl", "--viseme", "10", "--expression", "1", "-o", by_number, *SIZE)
    assert r.exit_code == 0, r.output + r.stderr
    assert by_name.read_bytes() == by_number.read_bytes()
    r = run("render", files / "face.wrl", "--expression", "surprised", "-o", by_name, *SIZE)
    assert r.exit_code == 2 and "did you mean surprise?" in r.stderr
    r = run("render", files / "face.wrl", "--viseme", "15", "-o", by_name, *SIZE)
    assert r.exit_code == 2 and "no viseme 15" in r.stderr


def test_a_misspelt_fap_gets_the_nearest_name(files, tmp_path):
    r = run("render", files / "face.wrl", "--fap", "jaw_open=600", "-o", tmp_path / "x.png", *SIZE)
    assert r.exit_code == 2 and "did you mean open_jaw?" in r.stderr
    assert "\"" not in r.stderr.splitlines()[-1]       # the KeyError's quotes are gone
    r = run("render", files / "face.wrl", "--fap", "open_jaw=wide", "-o", tmp_path / "x.png", *SIZE)
    assert r.exit_code == 2 and "'wide' is not a number" in r.stderr
    assert not (tmp_path / "x.png").exists()


def test_render_writes_a_real_jpeg(files, tmp_path):
    for name in ("x.jpg", "y.JPEG"):
        r = run("render", files / "face.wrl", "-o", tmp_path / name, *SIZE)
        assert r.exit_code == 0, r.output + r.stderr
        assert (tmp_path / name).read_bytes()[:3] == b"\xff\xd8\xff"
    from PIL import Image
    with Image.open(tmp_path / "x.jpg") as im:
        assert im.format == "JPEG" and im.size == (60, 70)


def test_convert_gzips_an_upper_case_wrz(files, tmp_path):
    r = run("convert", files / "face.wrl", tmp_path / "FACE.WRZ")
    assert r.exit_code == 0, r.output + r.stderr
    assert gzip.decompress((tmp_path / "FACE.WRZ").read_bytes()).startswith(b"#VRML V2.0 utf8")


# -- 5. info and validate read the .glb files we write ----------------------------------------

def test_info_reads_a_glb_we_wrote(files):
    r = run("info", files / "face.glb")
    assert r.exit_code == 0, r.output + r.stderr
    assert "Skin:" in r.output and "FAT:" in r.output and "visemes" in r.output
    facts = json.loads(run("info", "--json", files / "face.glb").output)
    assert facts["kind"] == "face" and facts["fat"]["visemes"] == 14
    assert {m["name"] for m in facts["meshes"]} >= {"Skin", "Tongue"}


def test_validate_reads_a_glb_we_wrote(files, tmp_path):
    r = run("validate", files / "face.glb")
    assert r.exit_code == 0, r.output
    assert "warning FBA017" in r.output and "not a VRML97 file" not in r.output
    (tmp_path / "broken.glb").write_bytes((files / "face.glb").read_bytes()[:3000])
    r = run("validate", tmp_path / "broken.glb")
    assert r.exit_code == 1 and "error FBA100" in r.output


def test_info_and_validate_read_the_glb_of_play(tmp_path):
    out = tmp_path / "talk.glb"
    assert run("play", "--example", "--demo-stream", "-o", out).exit_code == 0
    assert run("info", out).exit_code == 0
    assert run("validate", out).exit_code == 0


# -- 6. the licence ----------------------------------------------------------------------------

def test_license_matches_pyproject_and_three_js_keeps_its_own():
    tomllib = pytest.importorskip("tomllib")       # Python 3.11+
    text = (REPO / "LICENSE").read_text("utf-8")
    assert text.startswith("MIT License\n") and "Copyright (c) 2026 the mpeg4fba authors" in text
    project = tomllib.loads((REPO / "pyproject.toml").read_text("utf-8"))["project"]
    assert project["license"] == {"text": "MIT"}
    three = (REPO / "mpeg4fba" / "render" / "web" / "LICENSE").read_text("utf-8")
    assert three.startswith("The MIT License") and "three.js authors" in three
    assert any(d.lower().startswith("pillow") for d in project["dependencies"])
