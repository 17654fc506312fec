"""A batch's results table: one record (a dict) per task, written as ``results.csv``
(the columns of :data:`COLUMNS` for the task's kind) and ``results.json`` (every record
whole, plus the run's facts), both atomically.

>>> r = Results("validate", [{"name": "a", "status": "ok"}, {"name": "b", "status": "failed",
...                          "error": "b.wrl:3: bad"}])
>>> len(r), r.failed_count, r.counts()
(2, 1, {'ok': 1, 'failed': 1})
"""
from __future__ import annotations

import csv
import io
import json
import os
from typing import Iterator, Optional

from .._atomic import atomic_write

__all__ = ["Results", "COLUMNS", "STATUSES"]

#: A record's status: ``ok`` (done now), ``skipped`` (done before, unchanged: --resume),
#: ``invalid`` (validate: read, but not compliant), ``failed`` (an error, recorded).
STATUSES = ("ok", "skipped", "invalid", "failed")

#: The columns of results.csv for each kind of batch.
COLUMNS = {
    "clone": ["name", "status", "error", "seconds", "target", "points", "points_found",
              "lowest_confidence", "vertices", "faps", "visemes", "expressions",
              "errors", "warnings", "worst_fap_ratio", "folder"],
    "validate": ["name", "status", "error", "seconds", "kind", "errors", "warnings",
                 "worst_fap_ratio", "first_finding"],
    "play": ["name", "status", "error", "seconds", "face", "stream", "frames", "vertices",
             "outputs", "folder"],
}


class Results:
    """The records of one batch run, in the order of its inputs."""

    def __init__(self, kind: str, records: list, info: Optional[dict] = None):
        self.kind = kind
        self.records = list(records)
        #: the run's facts: source, options, workers, seconds...
        self.info = dict(info or {})

    def __len__(self) -> int:
        return len(self.records)

    def __iter__(self) -> Iterator[dict]:
        return iter(self.records)

    def __getitem__(self, name) -> dict:
        """The record named ``name`` (a number: the record at that place)."""
        if isinstance(name, int):
            return self.records[name]
        for r in self.records:
            if r.get("name") == name:
                return r
        raise KeyError(name)

    def counts(self) -> dict:
        """status -> how many, in :data:`STATUSES` order (present ones only)."""
        got = [r.get("status") for r in self.records]
        return {s: got.count(s) for s in STATUSES if s in got}

    @property
    def failed(self) -> list:
        """The records that did not end well (failed, or invalid for validate)."""
        return [r for r in self.records if r.get("status") in ("failed", "invalid")]

    @property
    def failed_count(self) -> int:
        return len(self.failed)

    def summary(self) -> str:
        """One line: how many of each status, and the time."""
        parts = [f"{n} {s}" for s, n in self.counts().items()]
        took = self.info.get("seconds")
        return (f"{len(self)} {self.kind} task{'s' if len(self) != 1 else ''}: "
                + (", ".join(parts) or "none") + (f" in {took:.1f} s" if took is not None else ""))

    def to_csv(self) -> str:
        """The table as CSV text (the kind's columns; lists joined with ``;``)."""
        out = io.StringIO()
        w = csv.writer(out, lineterminator="\n")
        cols = COLUMNS[self.kind]
        w.writerow(cols)
        for r in self.records:
            w.writerow([_cell(r.get(c)) for c in cols])
        return out.getvalue()

    def to_json(self) -> str:
        return json.dumps({"kind": self.kind, "info": self.info, "counts": self.counts(),
                           "results": self.records}, indent=1, default=str) + "\n"

    def write(self, folder: str) -> tuple:
        """Write ``results.csv`` and ``results.json`` into ``folder``; their paths."""
        paths = os.path.join(folder, "results.csv"), os.path.join(folder, "results.json")
        atomic_write(paths[0], self.to_csv())
        atomic_write(paths[1], self.to_json())
        return paths


def _cell(value) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, (list, tuple)):
        return ";".join(map(str, value))
    return str(value)
