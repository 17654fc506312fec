"""What every benchmark here shares: best-of timing."""
from __future__ import annotations

import gc
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
