"""The commands that make things to look at: demo, play, render."""
from __future__ import annotations

import os

import numpy as np
import pytest

from mpeg4fba.speech import available as speech_available
from click.testing import CliRunner

from mpeg4fba.cli import main
from mpeg4fba.formats.fap import read_fap
from mpeg4fba.formats.validate import validate
from mpeg4fba.formats.wrl_face import load_face, save_face
from mpeg4fba.models import reference_head
from mpeg4fba.models.phrase import demo_stream, make_demo_stream


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture(scope="module")
def demo_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("demo")
    r = run("demo", d, "--quick")
    assert r.exit_code == 0, r.output + r.stderr
    return d, r


def test_demo_writes_everything_and_it_is_valid(demo_dir):
    d, r = demo_dir
    spoken = speech_available()
    assert sorted(os.listdir(d)) == ["demo_phrase.fap"] + ["demo_phrase.wav"] * spoken + [
        "player.html", "preview.png", "report.txt", "target.glb", "target.wrl"]
    assert "written to" in r.stdout and "player.html" in r.stdout
    face = load_face(d / "target.wrl")
    assert len(face.fat.faps) == 66 and len(face.fat.visemes) == 14
    report = validate(str(d / "target.wrl"))
    assert report.ok and not [f for f in report.findings if f.rule == "FBA014"]
    assert "validation: OK" in (d / "report.txt").read_text()
    phrase = read_fap(d / "demo_phrase.fap")
    if spoken:
        # the phrase as eSpeak NG speaks it: as long as its sound, within a frame
        from mpeg4fba.formats.wav import read_wav
        samples, rate = read_wav(d / "demo_phrase.wav")
        assert abs(phrase.duration - len(samples) / rate) <= 1 / phrase.fps
        assert 'id="audio"' in (d / "player.html").read_text()
        assert "spoken by eSpeak NG" in (d / "report.txt").read_text()
    else:
        assert len(phrase) == len(demo_stream())
    assert (d / "target.glb").read_bytes()[:4] == b"glTF"


def test_demo_stream_package_data_matches_its_source():
    a, b = demo_stream(), make_demo_stream()
    assert np.array_equal(a.values, b.values) and np.array_equal(a.mask, b.mask)
    assert np.array_equal(a.visemes, b.visemes) and np.array_equal(a.expressions, b.expressions)
    # it speaks: several visemes, and an expression arc
    assert len(set(a.visemes[:, 0]) - {0}) >= 8
    assert a.expressions[:, 1].max() > 30


def test_render_single_turntable_and_grid(tmp_path):
    face = reference_head(resolution=0.5)
    save_face(face, tmp_path / "f.wrl")
    r = run("render", tmp_path / "f.wrl", "--fap", "open_jaw=800", "--size", "100x120",
            "-o", tmp_path / "a.png")
    assert r.exit_code == 0, r.output
    r = run("render", "--example", "--turntable", "4", "--size", "80x90", "-o", tmp_path / "t.png")
    assert r.exit_code == 0 and "(320x" in r.output
    other = reference_head(resolution=0.5, face_width=1.2, seed=3)
    other.fat.__init__()
    save_face(other, tmp_path / "o.wrl")
    r = run("render", tmp_path / "f.wrl", "--grid", tmp_path / "o.wrl", "--expression", "6",
            "--size", "80x90", "-o", tmp_path / "g.png")
    assert r.exit_code == 0, r.output + r.stderr


def test_render_errors_are_one_line(tmp_path):
    r = run("render", "--example", "--fap", "open_jaw", "-o", tmp_path / "x.png")
    assert r.exit_code == 2 and "NAME=VALUE" in r.stderr
    r = run("render", tmp_path / "missing.wrl", "-o", tmp_path / "x.png")
    assert r.exit_code == 1 and r.stderr.count("\n") == 1
    assert not (tmp_path / "x.png").exists()


def test_play_png_frames(tmp_path):
    r = run("play", "--example", "--demo-stream", "--frames", "10:12", "--size", "90x100",
            "-o", tmp_path / "frames")
    assert r.exit_code == 0, r.output + r.stderr
    assert sorted(os.listdir(tmp_path / "frames")) == ["frame_0010.png", "frame_0011.png"]
    r = run("play", "--example", "--demo-stream", "--frames", "0:999", "-o", tmp_path / "f2")
    assert r.exit_code == 2


@pytest.mark.parametrize("ext", ["glb", "wrl", "html"])
def test_play_writes_by_extension(tmp_path, ext):
    out = tmp_path / f"talk.{ext}"
    r = run("play", "--example", "--demo-stream", "-o", out)
    assert r.exit_code == 0, r.output + r.stderr
    assert out.stat().st_size > 10_000


def test_every_command_has_help_with_an_example():
    for cmd in ("validate", "info", "clone", "play", "convert", "render", "demo"):
        r = run(cmd, "--help")
        assert r.exit_code == 0 and "Examples:" in r.output, cmd


def test_an_unexpected_error_is_one_line(monkeypatch, tmp_path):
    import mpeg4fba.render.preview as preview

    def boom(*a, **k):
        raise RuntimeError("the renderer broke")

    monkeypatch.setattr(preview, "render_face", boom)
    r = run("render", "--example", "-o", tmp_path / "x.png")
    assert r.exit_code == 1
    assert r.stderr.strip().count("\n") == 0 and "RuntimeError: the renderer broke" in r.stderr
    assert "Traceback" not in r.stderr + r.output
