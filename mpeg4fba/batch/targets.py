"""What a batch works on: targets from file names, glob patterns and manifest CSVs,
each with a unique name (its output folder) and a content key for ``--resume``.

A manifest is a CSV file with a header row naming its columns: ``target`` (required:
a face file), ``points`` (its feature point file, optional per row) and ``name`` (its
output folder, optional).  Relative paths are relative to the manifest's folder.

>>> import os, tempfile
>>> d = tempfile.mkdtemp()
>>> for n in ("a.obj", "b.obj"):
...     _ = open(os.path.join(d, n), "w")
>>> with open(os.path.join(d, "list.csv"), "w") as f:
...     _ = f.write("target,points\\na.obj,\\nb.obj,b.json\\n")
>>> [(t.name, os.path.basename(t.points or "-")) for t in expand_targets([os.path.join(d, "list.csv")])]
[('a', '-'), ('b', 'b.json')]
"""
from __future__ import annotations

import csv
import glob
import hashlib
import json
import os
import re
from dataclasses import dataclass
from typing import Iterable, Optional, Sequence

from ..formats.errors import FormatError

__all__ = ["Target", "expand_targets", "read_manifest", "ManifestError", "content_key",
           "file_digest"]

_GLOB = re.compile(r"[*?[]")
#: A manifest larger than this is refused (a list of a million faces is about 100 MB).
MAX_MANIFEST = 256 * 2 ** 20


class ManifestError(FormatError):
    """A manifest CSV that can't be read: the file, the line and what was expected."""


@dataclass(frozen=True)
class Target:
    """One face to work on: ``path`` (its file), ``points`` (its feature point file or
    None) and ``name`` (its output folder's name, unique in the batch)."""

    path: str
    points: Optional[str] = None
    name: str = ""


def _stem(path: str) -> str:
    base = os.path.basename(path.rstrip("/\\")) or "face"
    for suffix in (".gz", ".wrz", ".wrl", ".obj", ".glb", ".gltf", ".ply", ".stl", ".off", ".fap"):
        if base.lower().endswith(suffix) and len(base) > len(suffix):
            base = base[: -len(suffix)]
    # a folder name anyone's shell and file system takes
    return re.sub(r"[^A-Za-z0-9._-]+", "_", base).strip("._") or "face"


def read_manifest(path: str) -> list:
    """The targets a manifest CSV lists (names not yet made unique)."""
    try:
        size = os.path.getsize(path)
        if size > MAX_MANIFEST:
            raise ManifestError(f"a manifest of {size} bytes is more than the "
                                f"{MAX_MANIFEST} a batch reads", path)
        with open(path, newline="", encoding="utf-8-sig") as f:
            rows = list(csv.reader(f))
    except UnicodeDecodeError as e:
        raise ManifestError(f"not UTF-8 text ({e.reason} at byte {e.start})", path) from None
    except csv.Error as e:
        raise ManifestError(f"not a CSV file ({e})", path) from None
    if not rows:
        raise ManifestError("empty: expected a header row naming the columns target, "
                            "points (optional) and name (optional)", path, line=1)
    header = [h.strip().lower() for h in rows[0]]
    if "target" not in header:
        raise ManifestError(f"the header row names the columns {', '.join(map(repr, rows[0]))}; "
                            "expected one called target (and optionally points and name)",
                            path, line=1)
    unknown = [h for h in header if h not in ("target", "points", "name", "")]
    if unknown:
        raise ManifestError(f"unknown column {unknown[0]!r}: expected target, points, name",
                            path, line=1)
    folder = os.path.dirname(os.path.abspath(path))
    out = []
    for line, row in enumerate(rows[1:], start=2):
        if not any(cell.strip() for cell in row):
            continue
        if len(row) > len(header):
            raise ManifestError(f"{len(row)} cells in a row of a {len(header)}-column "
                                "manifest", path, line=line)
        cells = dict(zip(header, (c.strip() for c in row)))
        if not cells.get("target"):
            raise ManifestError("no target in this row", path, line=line,
                                column=header.index("target") + 1)
        target = os.path.join(folder, cells["target"])
        points = os.path.join(folder, cells["points"]) if cells.get("points") else None
        out.append(Target(target, points, cells.get("name") or ""))
    if not out:
        raise ManifestError("no targets listed under the header row", path, line=2)
    return out


def expand_targets(specs: Iterable[str], points: Optional[str] = None) -> list:
    """Targets from file names, glob patterns (sorted matches; one matching nothing is
    an error) and manifests (``.csv``), in the order given, each once; names made
    unique (``head``, ``head-2``...).  ``points`` is a folder where a target without a
    point file may have ``<stem>.json`` or ``<stem>.fdp``."""
    found: list = []
    for spec in specs:
        spec = os.fspath(spec)
        if spec.lower().endswith(".csv"):
            found.extend(read_manifest(spec))
        elif _GLOB.search(spec) and not os.path.exists(spec):
            matches = sorted(glob.glob(spec))
            if not matches:
                raise FileNotFoundError(2, "no file matches the pattern", spec)
            found.extend(Target(m) for m in matches if os.path.isfile(m))
        else:
            found.append(Target(spec))
    seen, taken, out = set(), set(), []
    for t in found:
        key = os.path.abspath(t.path)
        if key in seen:
            continue
        seen.add(key)
        pts = t.points
        if pts is None and points is not None:
            for ext in (".json", ".fdp"):
                cand = os.path.join(points, _stem(t.path) + ext)
                if os.path.isfile(cand):
                    pts = cand
                    break
        name = base = _stem(t.name) if t.name else _stem(t.path)
        n = 2
        while name.lower() in taken:
            name, n = f"{base}-{n}", n + 1
        taken.add(name.lower())
        out.append(Target(t.path, pts, name))
    return out


def file_digest(path: Optional[str]) -> Optional[str]:
    """SHA-256 of a file's bytes (None for None or a file that can't be read)."""
    if path is None:
        return None
    h = hashlib.sha256()
    try:
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
    except OSError:
        return None
    return h.hexdigest()


def content_key(parts: Sequence) -> str:
    """One hash of the JSON-able ``parts`` (file digests, options, the version): what
    ``--resume`` compares.

    >>> content_key(["a", {"x": 1}]) == content_key(["a", {"x": 1}])
    True
    """
    text = json.dumps(list(parts), sort_keys=True, default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()
