"""The fast fuzzing budget of issue 21: a few hundred mutated inputs per reader, from
fixed seeds, each ending in a result or the reader's own located error.

``MPEG4FBA_FUZZ_N`` sets the inputs per reader (default 120); the long run with
process isolation, CPU and memory caps is ``benchmarks/fuzz_readers.py``.  Inputs
that once failed, minimised, live in ``tests/fuzz/regressions/<reader>/`` and are
read again here.
"""
from __future__ import annotations

import os
from pathlib import Path

import pytest

from _guards import alarm
from fuzz import harness as h

N = int(os.environ.get("MPEG4FBA_FUZZ_N", "120"))
REGRESSIONS = Path(__file__).parent / "regressions"


@pytest.mark.parametrize("name", sorted(h.READERS))
def test_mutated_inputs_end_in_a_result_or_the_readers_own_error(name, tmp_path):
    reader = h.READERS[name]
    pool = h.seeds(reader)
    assert pool, f"no seeds for {name}"
    outcomes, others = {}, []
    for i in range(N):
        data = h.make_input(reader, pool, i)
        with alarm(30, f"reading fuzz input {i} of {name}"):
            kind, detail = h.run_input(reader, data, tmp_path)
        outcomes[kind] = outcomes.get(kind, 0) + 1
        if kind == "other":
            others.append(f"input {i} ({len(data)} bytes): {detail}")
    assert not others, f"{len(others)} of {N} inputs raised something else:\n" + "\n".join(others)
    # the mutations must not be so blunt that nothing is ever read
    assert outcomes.get("error", 0) > 0


def _regressions():
    if not REGRESSIONS.is_dir():
        return []
    return sorted(p for p in REGRESSIONS.glob("*/*") if p.is_file() and p.parent.name in h.READERS)


@pytest.mark.parametrize("path", _regressions(), ids=lambda p: f"{p.parent.name}/{p.name}")
def test_kept_failures_stay_fixed(path, tmp_path):
    reader = h.READERS[path.parent.name]
    with alarm(30, f"reading {path.name}"):
        kind, detail = h.run_input(reader, path.read_bytes(), tmp_path)
    assert kind != "other", detail
