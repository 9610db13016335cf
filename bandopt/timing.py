"""Wall-clock timing for the benchmarks: the best of a few calls after a
warm-up, so compilation and caches are not counted."""

import math
import time
from collections.abc import Callable


def best_time(fn: Callable[[], object], repeat: int = 3) -> float:
    """Least wall-clock time of `repeat` calls of `fn` after one untimed
    warm-up call (compilation); a JAX array returned is waited for
    (`block_until_ready`) inside the timed span. [s]"""
    if repeat < 1:
        raise ValueError(f"repeat must be >= 1, got {repeat}.")
    fn()  # warm-up (compilation)
    best = math.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        if hasattr(out, "block_until_ready"):
            out.block_until_ready()
        best = min(best, time.perf_counter() - t0)
    return best
