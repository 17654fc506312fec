"""Tests of the mpeg4fba command line (click's CliRunner)."""
from __future__ import annotations

import gzip
import json

import pytest
from click.testing import CliRunner

from mpeg4fba import __version__, vrml
from mpeg4fba.cli import main
from mpeg4fba.vrml.examples import example_scene

SMALL = """#VRML V2.0 utf8
DEF Clock TimeSensor { loop TRUE }
DEF Spin OrientationInterpolator { key [ 0 1 ] keyValue [ 0 1 0 0, 0 1 0 3.14 ] }
DEF Body Transform {
  translation 0 0 -2
  children [
    Shape { geometry DEF Quad IndexedFaceSet {
      coord Coordinate { point [ 0 0 0, 1 0 0, 1 1 0, 0 1 0 ] }
      coordIndex [ 0 1 2 3 -1 ]
    } }
    Transform { translation 5 0 0 children Shape { geometry IndexedFaceSet {
      coord Coordinate { point [ 0 0 0, 1 0 0, 0 1 0 ] } coordIndex [ 0 1 2 ] } } }
  ]
}
ROUTE Clock.fraction_changed TO Spin.set_fraction
"""

BAD = """#VRML V2.0 utf8
Group {
  children [
    Shape { geometry Box { size 1 2 } }
  ]
}
"""


@pytest.fixture
def runner() -> CliRunner:
    return CliRunner()


@pytest.fixture
def small(tmp_path):
    p = tmp_path / "small.wrl"
    p.write_text(SMALL)
    return p


def test_info_on_a_file(runner, small):
    r = runner.invoke(main, ["info", str(small)])
    assert r.exit_code == 0, r.output
    out = r.stdout
    assert f"file: {small}" in out
    counts = dict(line.split() for line in out.splitlines() if line.startswith("  ")
                  and len(line.split()) == 2)
    assert counts["IndexedFaceSet"] == "2" and counts["Transform"] == "2"
    assert "ROUTEs: 1" in out and "DEFs: 4" in out and "meshes: 2" in out
    assert "Quad: 4 vertices, 2 triangles" in out
    assert "Body/Transform/Shape/IndexedFaceSet: 3 vertices, 1 triangles" in out
    assert "bounds: (0, 0, -2) to (6, 1, -2)" in out


def test_info_example(runner):
    r = runner.invoke(main, ["info", "--example"])
    assert r.exit_code == 0, r.output
    assert "HeadMesh: 642 vertices, 1280 triangles" in r.stdout
    assert "PROTOs: LoopingClock" in r.stdout and "ROUTEs: 2" in r.stdout


def test_info_json(runner, small):
    r = runner.invoke(main, ["info", "--json", str(small)])
    assert r.exit_code == 0, r.output
    facts = json.loads(r.stdout)
    assert facts["file"] == str(small)
    assert facts["nodes"]["IndexedFaceSet"] == 2 and list(facts["nodes"])[0] in (
        "Transform", "Shape", "IndexedFaceSet", "Coordinate")
    counts = list(facts["nodes"].values())
    assert counts == sorted(counts, reverse=True)
    assert facts["routes"] == 1 and facts["defs"] == 4
    assert [(m["name"], m["vertices"], m["triangles"]) for m in facts["meshes"]] == [
        ("Quad", 4, 2), (None, 3, 1)]
    assert facts["bounds"] == {"min": [0, 0, -2], "max": [6, 1, -2]}
    r = runner.invoke(main, ["info", "--example", "--json"])
    assert json.loads(r.stdout)["protos"] == ["LoopingClock"]


def test_info_needs_file_or_example(runner, small):
    assert runner.invoke(main, ["info"]).exit_code == 2
    assert runner.invoke(main, ["info", "--example", str(small)]).exit_code == 2
    assert runner.invoke(main, ["info", "--no-such-option"]).exit_code == 2


def test_convert_round_trip(runner, tmp_path):
    src, out = tmp_path / "in.wrl", tmp_path / "out.wrl"
    vrml.dump(example_scene(2), src)
    r = runner.invoke(main, ["convert", str(src), str(out)])
    assert r.exit_code == 0, r.output
    assert r.stdout.count("\n") == 1 and f"wrote {out}" in r.stdout
    assert vrml.load(out) == vrml.load(src) == example_scene(2)


def test_convert_gzip(runner, small, tmp_path):
    out = tmp_path / "out.wrl.gz"
    r = runner.invoke(main, ["convert", str(small), str(out)])
    assert r.exit_code == 0, r.output
    data = out.read_bytes()
    assert data[:2] == b"\x1f\x8b"
    assert gzip.decompress(data).startswith(b"#VRML V2.0 utf8")
    assert vrml.load(out) == vrml.load(small)


def test_bad_input_gives_one_line(runner, tmp_path):
    bad = tmp_path / "bad.wrl"
    bad.write_text(BAD)
    for args in (["info", str(bad)], ["convert", str(bad), str(tmp_path / "o.wrl")]):
        r = runner.invoke(main, args)
        assert r.exit_code == 1
        assert "Traceback" not in r.output
        lines = r.stderr.splitlines()
        assert len(lines) == 1, r.stderr
        assert lines[0].startswith(f"mpeg4fba: error: {bad}:4:")
        assert "SFVec3f takes 3 numbers" in lines[0] or "Box.size" in lines[0]
    assert not (tmp_path / "o.wrl").exists()


def test_verbose_shows_traceback(runner, tmp_path):
    bad = tmp_path / "bad.wrl"
    bad.write_text(BAD)
    r = runner.invoke(main, ["--verbose", "info", str(bad)])
    assert r.exit_code == 1
    assert "Traceback" in r.stderr and r.stderr.rstrip().splitlines()[-1].startswith(
        "mpeg4fba: error: ")


def test_missing_file(runner, tmp_path):
    missing = tmp_path / "nope.wrl"
    r = runner.invoke(main, ["info", str(missing)])
    assert r.exit_code == 1
    assert r.stderr.strip() == f"mpeg4fba: error: {missing}: can't read the file: " \
                               "No such file or directory"
    r = runner.invoke(main, ["convert", str(missing), str(tmp_path / "o.wrl")])
    assert r.exit_code == 1 and "No such file" in r.stderr


def test_lenient(runner, tmp_path):
    odd = tmp_path / "odd.wrl"
    odd.write_text("#VRML V2.0 utf8\nGroup { children [ Sparkle { glow 1 } ] }\n")
    r = runner.invoke(main, ["info", str(odd)])
    assert r.exit_code == 1 and "unknown node type 'Sparkle'" in r.stderr
    r = runner.invoke(main, ["info", "--lenient", str(odd)])
    assert r.exit_code == 0, r.output
    assert "mpeg4fba: warning:" in r.stderr and "Sparkle" in r.stdout
    out = tmp_path / "odd2.wrl"
    r = runner.invoke(main, ["convert", "--lenient", str(odd), str(out)])
    assert r.exit_code == 0, r.output
    assert "Sparkle" in out.read_text()


def test_help_and_version(runner):
    for cmd in ("info", "convert"):
        r = runner.invoke(main, [cmd, "--help"])
        assert r.exit_code == 0 and f"mpeg4fba {cmd} " in r.stdout
    r = runner.invoke(main, ["--version"])
    assert r.exit_code == 0 and __version__ in r.stdout


def test_lenient_cycle_warns_in_one_line_each(runner, tmp_path):
    cyc = tmp_path / "cycle.wrl"
    cyc.write_text("#VRML V2.0 utf8\nDEF A Group { children [ Shape {} USE A ] }\n")
    r = runner.invoke(main, ["info", "--lenient", str(cyc)])
    assert r.exit_code == 0, r.output
    lines = r.stderr.splitlines()
    assert len(lines) == 2 and all(x.startswith("mpeg4fba: warning: ") for x in lines)
    assert "its own ancestor" in lines[1]


def test_help_lists_every_subcommand_with_its_own_first_paragraph():
    # --help lists the subcommands from mpeg4fba.cli.COMMANDS without importing them
    import click

    from mpeg4fba.cli import COMMANDS

    ctx = click.Context(main)
    assert main.list_commands(ctx) == sorted(COMMANDS)
    for name, text in COMMANDS.items():
        cmd = main.get_command(ctx, name)
        assert cmd is not None and cmd.name == name
        assert " ".join(cmd.help.split("\n\n")[0].split()) == text, name


def test_help_does_not_import_the_heavy_parts():
    import subprocess
    import sys

    code = ("import sys; from mpeg4fba.cli import main\n"
            "try:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
            "print(sorted(m for m in ('numpy', 'scipy', 'lark', 'mpeg4fba.cloning') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == "[]"
