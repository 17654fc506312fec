"""pytest plugin: fixtures for testing FAP playback (see :mod:`mpeg4fba.testing`).

Installed with the package, it is loaded through the ``pytest11`` entry point; without
an install, load it with ``pytest -p mpeg4fba.pytest_plugin`` or
``pytest_plugins = ["mpeg4fba.pytest_plugin"]`` in the root ``conftest.py``.

Fixtures:

* ``fap_compliance`` -- :func:`mpeg4fba.testing.assert_fap_compliant`;
* ``playback_golden`` -- ``playback_golden(face, stream, name=None, *, atol=1e-6)``
  compares the playback with ``golden/<test name>.npz`` beside the test file (``name``
  replaces the test name, for several golden files in one test) and returns that path.

The option ``--update-golden`` (or ``MPEG4FBA_UPDATE_GOLDEN=1``) writes the golden files
instead of comparing.
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import Callable, Optional

import pytest

from .testing import assert_fap_compliant, assert_playback_matches

__all__ = ["golden_name"]


def golden_name(test_name: str) -> str:
    """A file name for a test (parametrised ids included).

    >>> golden_name("test_jaw[open-1024]")
    'test_jaw-open-1024'
    """
    return re.sub(r"[^A-Za-z0-9_.-]+", "-", test_name).strip("-.") or "golden"


def pytest_addoption(parser) -> None:
    group = parser.getgroup("mpeg4fba", "MPEG-4 face animation")
    group.addoption("--update-golden", action="store_true", default=False,
                    help="write the golden playback files of the playback_golden fixture "
                         "instead of comparing with them")


@pytest.fixture
def fap_compliance() -> Callable:
    """:func:`mpeg4fba.testing.assert_fap_compliant`."""
    return assert_fap_compliant


@pytest.fixture
def playback_golden(request) -> Callable:
    """``check(face, stream, name=None, *, atol=1e-6)``: compare with (or, with
    ``--update-golden``, write) ``golden/<test name>.npz`` in the test file's folder."""
    folder = Path(str(request.node.path)).parent / "golden"
    update = bool(request.config.getoption("update_golden", default=False))
    default = golden_name(request.node.name)

    def check(face, stream, name: Optional[str] = None, *, atol: float = 1e-6) -> Path:
        path = folder / f"{golden_name(name) if name else default}.npz"
        assert_playback_matches(face, stream, path, atol=atol, update=update)
        return path

    return check
