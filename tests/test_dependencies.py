"""Dependencies: every range is bounded, and no library's deprecation reaches the user.

Click 8.5 deprecated ``click.get_text_stream``; with the test filter that turns our
modules' DeprecationWarnings into errors the demo died under pytest, and only where an
older click happened to be installed did the suite pass.  ``.ci/run`` now installs the
newest versions the ranges allow in a fresh venv; these tests make a deprecation in a
command visible (``--verbose`` shows it) and harmless (never a failed command).
"""
from __future__ import annotations

import importlib
import re
import sys
import warnings
from pathlib import Path

import pytest
from click.testing import CliRunner

from mpeg4fba.cli import main

REPO = Path(__file__).resolve().parents[1]
DEPRECATIONS = (DeprecationWarning, PendingDeprecationWarning)


def run_recording(*args):
    """Run the command; (result, the deprecation warnings it showed)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = CliRunner().invoke(main, [str(a) for a in args])
    return result, [w for w in caught if issubclass(w.category, DEPRECATIONS)]


def test_progress_bars_use_no_deprecated_api(tmp_path):
    result, shown = run_recording("--verbose", "play", "--example", "--demo-stream",
                                  "--frames", "0:2", "--size", "40x40", "-o", tmp_path / "f")
    assert result.exit_code == 0, result.output + result.stderr
    assert not shown, [f"{w.filename}:{w.lineno}: {w.message}" for w in shown]


def test_a_library_deprecation_never_fails_a_command(monkeypatch):
    # the module (imported on first use; the attribute of mpeg4fba.cli is the command)
    info = importlib.import_module("mpeg4fba.cli.info")
    real = info.scene_info

    def deprecated(*a, **k):
        # As a library warns: attributed to our module, which pytest's filter (and a
        # user's -W error) turns into an exception.
        warnings.warn_explicit("old API", DeprecationWarning, info.__file__, 1,
                               module="mpeg4fba.cli.info")
        return real(*a, **k)

    monkeypatch.setattr(info, "scene_info", deprecated)
    with warnings.catch_warnings():
        warnings.filterwarnings("error", category=DeprecationWarning)
        result = CliRunner().invoke(main, ["info", "--example"])
        assert result.exit_code == 0, result.output + result.stderr
        assert "old API" not in result.stderr            # hidden without --verbose
        with pytest.warns(DeprecationWarning, match="old API"):   # shown with --verbose
            result = CliRunner().invoke(main, ["--verbose", "info", "--example"])
        assert result.exit_code == 0, result.output + result.stderr


@pytest.mark.skipif(sys.version_info < (3, 11), reason="tomllib is Python 3.11+")
def test_every_dependency_has_a_bounded_range():
    import tomllib
    project = tomllib.loads((REPO / "pyproject.toml").read_text("utf-8"))["project"]
    deps = project["dependencies"] + project["optional-dependencies"]["test"]
    build_only = {"setuptools", "wheel"}   # the test that builds a wheel needs any recent one
    for dep in deps:
        name = re.match(r"[A-Za-z0-9_.-]+", dep).group(0)
        if name in build_only:
            continue
        assert re.search(r">=\s*[0-9]", dep) and re.search(r"<\s*[0-9]", dep), \
            f"{dep!r}: give it a tested lower bound and an upper bound at the next major"
    lowest = (REPO / ".ci" / "lowest-constraints.txt").read_text("utf-8")
    for dep in deps:
        name = re.match(r"[A-Za-z0-9_.-]+", dep).group(0)
        if name not in build_only:
            low = re.search(r">=\s*([0-9][0-9.]*)", dep).group(1)
            assert re.search(rf"^{re.escape(name)}=={re.escape(low)}(\.\*)?$", lowest,
                             re.M | re.I), f"{name}: .ci/lowest-constraints.txt must pin {low}"
