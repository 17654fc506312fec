#!/usr/bin/env python
"""Read/write speed of the ASCII ``.fap`` codec (``mpeg4fba.formats.fap``).

    python benchmarks/bench_fap_read.py [--quick] [--frames N] [--profile]

Cases (see benchmarks/README.md), each a generated file of 100,000 frames by default:

1. constant mask: the 42 FAPs of Xface ``joy.fap`` in every frame, small integers,
   CRLF line ends with a trailing space as the Xface files have them;
2. varying masks: the same FAPs with about 10% of the mask bits flipped per frame (blinks,
   FAPs dropped), FAP 1 (viseme) in one frame of 8, LF line ends;
3. floats (informational): case 1 with values of 2 decimals, the float parsing path.

Each timing is ``time.perf_counter`` around one call, after one warm-up call, best of 3
(best of 1 with ``--quick``).  Reads time ``read_fap(path)`` (file read included); writes
time ``write_fap(stream, path)`` (formatting and the atomic write).  MB = 10**6 bytes.
The peak memory of one more read is taken with ``tracemalloc`` (informational).
A markdown table for the README is printed at the end.
"""
from __future__ import annotations

import argparse
import cProfile
import gc
import io
import os
import platform
import pstats
import sys
import tempfile
import time
import tracemalloc
import warnings
from pathlib import Path
from typing import Callable

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))  # benchmark this working tree, not an installed copy

from benchmarks.timing import best_of, profile_top  # noqa: E402

import numpy as np  # noqa: E402

from mpeg4fba.fba.stream import FapStream  # noqa: E402
from mpeg4fba.fba.tables import FAP  # noqa: E402
from mpeg4fba.formats.fap import read_fap, write_fap  # noqa: E402

MB = 1e6
TARGET = 20.0   # MB/s, reading
#: The FAPs of Xface ``Faps/joy.fap`` (42: the mouth, eyelids, eyeballs, cheeks, head).
XFACE_FAPS = list(range(3, 27)) + list(range(39, 43)) + list(range(48, 61)) + [63]


def xface_like(frames: int, seed: int = 0, decimals: int = 0) -> FapStream:
    """Smooth FAP curves in range (small integers unless ``decimals``), constant mask."""
    rng = np.random.default_rng(seed)
    cols = np.array(XFACE_FAPS) - 1
    t = np.arange(frames)[:, None] / 25.0
    lo = np.array([FAP[f].range[0] for f in XFACE_FAPS])
    hi = np.array([FAP[f].range[1] for f in XFACE_FAPS])
    amp = 0.05 * (hi - lo) * rng.random(len(cols))
    centre = np.where(lo < 0, 0.0, amp)                    # one-sided FAPs stay >= 0
    curve = centre + amp * np.sin(2 * np.pi * rng.uniform(0.1, 1.0, len(cols)) * t
                                  + rng.uniform(0, 6.3, len(cols)))
    values = np.zeros((frames, 68))
    values[:, cols] = np.clip(np.round(curve, decimals), lo, hi)
    mask = np.zeros((frames, 68), dtype=bool)
    mask[:, cols] = True
    return FapStream(values, mask, 25, name=r"C:\Users\me\faps\generated.fap")


def varying(frames: int, seed: int = 1) -> FapStream:
    """:func:`xface_like` with ~10% of mask bits flipped per frame and a viseme every 8th."""
    base = xface_like(frames, seed)
    rng = np.random.default_rng(seed)
    mask = base.mask ^ (rng.random(base.mask.shape) < 0.1)
    mask[:, 0] = np.arange(frames) % 8 == 0
    mask[:, 1] = False
    values = np.where(mask, base.values, 0.0)
    values[:, 2] = np.abs(values[:, 2])
    values[:, 13] = np.clip(np.abs(values[:, 13]), 0, 600)  # thrust_jaw, one-sided
    values[:, 46] = np.abs(values[:, 46])                    # tongue_roll, one-sided
    visemes = np.stack([rng.integers(0, 15, frames), rng.integers(0, 15, frames),
                        rng.integers(0, 64, frames), np.zeros(frames, int)], axis=1)
    return FapStream(values, mask, 25, visemes=visemes, name="varying")


def to_crlf(path: Path) -> None:
    """Rewrite a file with Xface's line ends: a trailing space, then CRLF."""
    data = path.read_bytes().replace(b"\n", b" \r\n")
    path.write_bytes(data)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="best of 1 instead of best of 3")
    ap.add_argument("--frames", type=int, default=100_000, help="frames per file (100000)")
    ap.add_argument("--profile", action="store_true",
                    help="cProfile one read of each case and print the top functions")
    args = ap.parse_args(argv)
    reps = 1 if args.quick else 3
    print(f"Python {platform.python_version()}, numpy {np.__version__}, {platform.machine()}, "
          f"{os.cpu_count()} CPUs; best of {reps}; {args.frames:,} frames per file", flush=True)
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench-fap-") as tmp:
        cases = [("constant mask, 42 FAPs, ints, CRLF", xface_like(args.frames), True, TARGET),
                 ("varying masks + visemes, ints, LF", varying(args.frames), False, TARGET),
                 ("constant mask, 2-decimal floats, LF", xface_like(args.frames, decimals=2),
                  False, None)]
        for k, (case, stream, crlf, target) in enumerate(cases):
            path = Path(tmp) / f"case{k}.fap"
            wsec, _ = best_of(lambda: write_fap(stream, path), reps)
            wsize = path.stat().st_size
            if crlf:
                to_crlf(path)
            size = path.stat().st_size
            with warnings.catch_warnings():
                warnings.simplefilter("error")      # a generated file must read cleanly
                rsec, back = best_of(lambda: read_fap(path), reps)
            if back != stream:
                raise SystemExit(f"{case}: the stream read back differs from the one written")
            gc.collect()
            tracemalloc.start()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                read_fap(path)
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
            read_mbps, write_mbps = size / MB / rsec, wsize / MB / wsec
            met = "-" if target is None else ("yes" if read_mbps >= target else "**no**")
            print(f"{case:<40} {size / MB:7.2f} MB  read {rsec:7.4f} s {read_mbps:7.1f} MB/s"
                  + (f" (target >= {target:g}: {'met' if read_mbps >= target else 'MISSED'})"
                     if target else "")
                  + f"   write {wsec:7.4f} s {write_mbps:7.1f} MB/s"
                  + f"   read peak {peak / MB:.0f} MB ({peak / size:.1f}x)", flush=True)
            if args.profile:
                print(profile_top(lambda: read_fap(path)))
            rows.append(f"| {case} | {len(stream):,} | {size / MB:.2f} | {rsec:.4f} | "
                        f"{read_mbps:.1f} MB/s | {'>= %g MB/s' % target if target else '-'} | "
                        f"{met} | {wsec:.4f} | {write_mbps:.1f} MB/s | "
                        f"{peak / MB:.0f} MB ({peak / size:.1f}x) |")
    print()
    print("| Case | Frames | Size (MB) | Read (s) | Read speed | Target | Met | Write (s) "
          "| Write speed | Read peak memory |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
