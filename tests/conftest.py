"""Shared test helpers: where ``../shared`` is, and the VRML corpus manifest.

``../shared`` (reference data beside the repository, never copied into it) is found
through the environment variable ``MPEG4FBA_SHARED`` if set, else ``<repo>/../shared``.
Tests that need it take the ``shared_dir`` fixture, which skips with a clear reason
when it is absent (a user's fresh clone has none).

Tests taking a ``corpus_row`` argument (a manifest row as a dict, plus ``_role``:
positive/negative/extension and ``_types``: the listed non-VRML97 node types) and marked ``@pytest.mark.corpus_role(...)``
are parametrised here over the matching rows of ``data/vrml-corpus/MANIFEST.tsv``;
without the corpus they get one skipped case, so collection never fails.  A test
module may define ``CORPUS_XFAIL = {(test_name, local_path): "BUG: ..."}`` to mark
single rows as strict xfails.
"""
from __future__ import annotations

import csv
import os
from pathlib import Path
from typing import Optional

import pytest

REPO = Path(__file__).resolve().parents[1]
MANIFEST = Path("data") / "vrml-corpus" / "MANIFEST.tsv"


def locate_shared() -> tuple[Optional[Path], str]:
    """(path of ../shared, "") if it is there, else (None, why it is not)."""
    env = os.environ.get("MPEG4FBA_SHARED")
    if env:
        path, origin = Path(env), f"MPEG4FBA_SHARED={env!r}"
    else:
        path, origin = REPO.parent / "shared", "<repo>/../shared"
    if path.is_dir():
        return path, ""
    return None, (f"../shared is absent: {origin} ({path}) is not a directory; set "
                  "MPEG4FBA_SHARED to the shared data folder to run these tests")


def corpus_rows(shared: Optional[Path]) -> tuple[list, str]:
    """(rows of the VRML corpus manifest as dicts, "") or ([], why there are none)."""
    if shared is None:
        return [], locate_shared()[1]
    manifest = shared / MANIFEST
    if not manifest.is_file():
        return [], f"../shared is absent: {manifest} does not exist"
    with open(manifest, newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f, delimiter="\t"))
    for row in rows:  # derived columns, so tests need not import this module
        row["_role"] = row_role(row)
        row["_types"] = row_types(row)
    return rows, ""


def row_role(row: dict) -> str:
    """positive, negative or extension: the role column's first word before '+'."""
    return row["role"].split("+", 1)[0].strip()


def row_types(row: dict) -> list:
    """The non-VRML97 node types listed for a row ('-' or empty: none)."""
    text = (row.get("non_vrml97_node_types") or "").strip()
    if text in ("", "-"):
        return []
    return [t.strip() for t in text.replace(";", ",").split(",") if t.strip()]


def pytest_configure(config):
    config.addinivalue_line("markers", "slow: takes more than 30 s")
    config.addinivalue_line(
        "markers", "corpus_role(*roles): parametrise corpus_row over manifest rows of these roles")


def pytest_generate_tests(metafunc):
    if "corpus_row" not in metafunc.fixturenames:
        return
    marker = metafunc.definition.get_closest_marker("corpus_role")
    roles = set(marker.args) if marker else {"positive", "negative", "extension"}
    shared, reason = locate_shared()
    rows, why = corpus_rows(shared)
    xfails = getattr(metafunc.module, "CORPUS_XFAIL", {})
    params = []
    for row in rows:
        if row["_role"] not in roles:
            continue
        marks = []
        bug = xfails.get((metafunc.function.__name__, row["local_path"]))
        if bug:
            marks.append(pytest.mark.xfail(strict=True, reason=bug))
        params.append(pytest.param(row, id=row["local_path"], marks=marks))
    if not params:
        reason = why or reason or f"no manifest rows with role {sorted(roles)}"
        params = [pytest.param(None, id="no-corpus", marks=pytest.mark.skip(reason=reason))]
    metafunc.parametrize("corpus_row", params)


@pytest.fixture(scope="session")
def shared_dir() -> Path:
    """Path of ../shared, or skip the test with the reason it is absent."""
    path, reason = locate_shared()
    if path is None:
        pytest.skip(reason)
    return path


@pytest.fixture(scope="session")
def ict_data(shared_dir):
    """The ICT-FaceKit arrays (``benchmarks.ict.load_ict``), or skip when the file is
    absent from ../shared."""
    from benchmarks import ict
    try:
        return ict.load_ict(shared_dir)
    except FileNotFoundError as e:
        pytest.skip(str(e))


@pytest.fixture(scope="session")
def shared_dir_or_none() -> Optional[Path]:
    """Path of ../shared, or None (for tests with a generated fallback)."""
    return locate_shared()[0]


@pytest.fixture(scope="session")
def corpus_manifest(shared_dir) -> list:
    """All manifest rows (dicts, plus "_role" and "_types"), or skip."""
    rows, why = corpus_rows(shared_dir)
    if not rows:
        pytest.skip(why or "../shared is absent: the VRML corpus manifest is empty")
    return rows


@pytest.fixture(scope="session")
def corpus_dir(shared_dir) -> Path:
    """The VRML corpus folder (files are named by the manifest's local_path)."""
    d = shared_dir / MANIFEST.parent
    if not (d / MANIFEST.name).is_file():
        pytest.skip(f"../shared is absent: {d / MANIFEST.name} does not exist")
    return d
