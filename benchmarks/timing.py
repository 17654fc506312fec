"""What every benchmark here shares: best-of timing."""
from __future__ import annotations

import cProfile
import gc
import io
import pstats
import time
from typing import Callable


def best_of(fn: Callable, reps: int) -> tuple:
    """``(best seconds, last result)``: one warm-up call, then ``reps`` timed ones."""
    result = fn()
    best = float("inf")
    for _ in range(reps):
        result = None
        gc.collect()
        t0 = time.perf_counter()
        result = fn()
        best = min(best, time.perf_counter() - t0)
    return best, result


def profile_top(fn: Callable, n: int = 12) -> str:
    """The ``n`` functions with the most own time in one call of ``fn``."""
    prof = cProfile.Profile()
    prof.enable()
    fn()
    prof.disable()
    out = io.StringIO()
    pstats.Stats(prof, stream=out).sort_stats("tottime").print_stats(n)
    return out.getvalue()
