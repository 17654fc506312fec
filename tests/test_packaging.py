"""The wheel carries the grammar and the node catalogue: a non-editable install works."""
import subprocess
import sys
import zipfile

import pytest


def test_wheel_contains_grammar_and_catalogue(tmp_path):
    repo = __import__("pathlib").Path(__file__).resolve().parents[1]
    try:  # the build backend, used without isolation so that no download is needed
        import setuptools  # noqa: F401
        import wheel  # noqa: F401
    except ImportError:
        pytest.skip("setuptools and wheel (the test extras) are needed to build the wheel offline")
    run = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
                          "-q", "-w", str(tmp_path), str(repo)], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    wheel = next(tmp_path.glob("mpeg4fba-*.whl"))
    names = set(zipfile.ZipFile(wheel).namelist())
    assert "mpeg4fba/grammars/vrml97.lark" in names
    assert "mpeg4fba/vrml/data/nodes.tsv" in names
    # the point editor's page and script, and the vendored three.js the pages inline
    for rel in ("render/pages/point_editor.html", "render/pages/point_editor.js",
                "render/web/three.module.min.js"):
        assert f"mpeg4fba/{rel}" in names, f"{rel} is missing from the wheel: pyproject's package-data"
    # Every subpackage of the source tree is in the wheel (the package list is explicit).
    for init in (repo / "mpeg4fba").rglob("__init__.py"):
        rel = init.relative_to(repo).as_posix()
        assert rel in names, f"{rel} is missing from the wheel: add it to pyproject's packages"
    with zipfile.ZipFile(wheel) as z:
        assert z.read("mpeg4fba/grammars/vrml97.lark") == (repo / "grammars" / "vrml97.lark").read_bytes()


def test_grammar_is_found_as_package_data_when_installed():
    from importlib import resources

    from mpeg4fba.vrml import reader
    text = reader._grammar_text()
    assert "NUMBERS" in text and "node_head" in text
    try:
        packaged = resources.files("mpeg4fba.grammars").joinpath("vrml97.lark").read_text("utf-8")
    except ModuleNotFoundError:
        pytest.skip("running from a source tree that is not installed")
    assert packaged == text
