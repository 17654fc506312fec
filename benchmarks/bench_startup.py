#!/usr/bin/env python
"""Start-up time of mpeg4fba: what every command-line call and every ``import`` pays.

    python benchmarks/bench_startup.py [--runs N]

Each case is a fresh ``python`` process (``subprocess.run``, wall time, best of N = 7
by default, after one warm-up run so the files are in the page cache), beside bare
Python (``python -c pass``) measured the same way:

* ``import mpeg4fba.vrml`` (the codec's names load on first use);
* ``from mpeg4fba.vrml import loads`` (the reader, numpy and lark loaded);
* reading a one-node file (the parser built as well);
* ``import mpeg4fba`` (the package; its names load on first use);
* ``mpeg4fba --help`` (``python -m mpeg4fba --help``; subcommands are imported when run);
* ``mpeg4fba convert`` of a small PROTO file and of a 14 kB one, the whole process,
  beside Castle Game Engine's ``tovrmlx3d`` converting the same files (where it is on
  PATH: Debian's view3dscene package has it; skipped with a reason otherwise).

Issue 20's goals: ``--help`` and ``import mpeg4fba.vrml`` under 0.3 s; ``convert`` of a
small file within 3x of ``tovrmlx3d``.
"""
from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
GOAL = 0.3

SMALL = """#VRML V2.0 utf8
PROTO Limb [ field SFVec3f size 1 1 1 exposedField SFColor colour 0.8 0.6 0.5 ]
{ Transform { children Shape { appearance Appearance { material Material {
  diffuseColor IS colour } } geometry Box { size IS size } } } }
DEF Body Transform { children [ Limb { size 0.3 0.6 0.2 }
  Transform { translation 0 0.5 0 children Limb { size 0.2 0.2 0.2 } } ] }
"""


def proto_file(target: int = 14_000) -> str:
    """A PROTO file of about ``target`` bytes: SMALL's PROTO, then many instances."""
    out = [SMALL]
    i = 0
    while sum(map(len, out)) < target:
        i += 1
        out.append(f"Transform {{ translation {i * 0.25:g} {i % 7 * 0.5:g} 0 rotation 0 1 0 "
                   f"{i * 0.1:.3g} children [ Limb {{ size {0.1 + i % 5 * 0.05:.3g} 0.4 0.2 "
                   f"colour {i % 10 / 10:g} 0.5 0.5 }} ] }}\n")
    return "".join(out)


def best(cmd: list, runs: int, cwd: Path) -> float:
    subprocess.run(cmd, cwd=cwd, check=True, capture_output=True)          # warm-up
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        subprocess.run(cmd, cwd=cwd, check=True, capture_output=True)
        times.append(time.perf_counter() - t0)
    return min(times)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=7)
    args = ap.parse_args(argv)
    py = sys.executable
    with tempfile.TemporaryDirectory(prefix="mpeg4fba-startup-") as tmp:
        small = Path(tmp) / "limbs.wrl"
        small.write_text(SMALL)
        big = Path(tmp) / "limbs14k.wrl"
        big.write_text(proto_file())
        out = Path(tmp) / "out.wrl"
        castle = shutil.which("tovrmlx3d")
        cases = [
            ("bare Python (python -c pass)", [py, "-c", "pass"], None),
            ("import mpeg4fba.vrml", [py, "-c", "import mpeg4fba.vrml"], GOAL),
            ("from mpeg4fba.vrml import loads", [py, "-c", "from mpeg4fba.vrml import loads"], None),
            ("read a one-node file (parser built)",
             [py, "-c", "import mpeg4fba.vrml as v; v.loads('#VRML V2.0 utf8\\nGroup {}')"], None),
            ("import mpeg4fba", [py, "-c", "import mpeg4fba"], None),
            ("mpeg4fba --help", [py, "-m", "mpeg4fba", "--help"], GOAL),
            (f"mpeg4fba convert ({len(SMALL)} B PROTO file)",
             [py, "-m", "mpeg4fba", "convert", str(small), str(out)], None),
            (f"mpeg4fba convert ({big.stat().st_size / 1000:.0f} kB PROTO file)",
             [py, "-m", "mpeg4fba", "convert", str(big), str(out)], None),
        ]
        peers = {}   # our convert case -> Castle's command on the same file
        if castle:
            peers[cases[-2][0]] = [castle, str(small), "--encoding=classic"]
            peers[cases[-1][0]] = [castle, str(big), "--encoding=classic"]
        print(f"# start-up, best of {args.runs} fresh processes (wall time), Python "
              f"{sys.version.split()[0]}")
        bare = None
        rows = []
        for name, cmd, goal in cases:
            t = best(cmd, args.runs, REPO)
            bare = t if bare is None else bare
            verdict = "" if goal is None else f"   goal < {goal} s: {'met' if t < goal else 'MISSED'}"
            print(f"{name:<45} {t:6.3f} s  ({t - bare:+.3f} s over bare Python){verdict}")
            rows.append((name, t, goal))
            if name in peers:
                c = best(peers[name], args.runs, REPO)
                print(f"{'  Castle tovrmlx3d, same file':<45} {c:6.3f} s  ours/theirs "
                      f"{t / c:.1f}x   goal <= 3x: {'met' if t <= 3 * c else 'MISSED'} "
                      f"(bare Python alone is {bare / c:.1f}x)")
            elif "convert" in name and not castle:
                print("  Castle tovrmlx3d: skipped (not on PATH; Debian: apt install view3dscene)")
    print("\nREADME rows:")
    for name, t, goal in rows[1:]:
        print(f"| start-up: {name} (`benchmarks/bench_startup.py`) | - | {t:.2f} s "
              f"({t - bare:+.2f} s over bare Python) | {'< %.1f s' % goal if goal else ''} | | |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
