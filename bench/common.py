"""Helpers for benchmarks: timing with repeats, and the JSON line format."""

from __future__ import annotations

import json
import os
import platform
import time
from typing import Any, Callable


def emit(bench: str, value: float, unit: str, **context: Any) -> None:
    """Print one benchmark result as a JSON line."""
    record = {"bench": bench, "value": float(value), "unit": unit}
    record.update(context)
    record.setdefault("cpus", os.cpu_count())
    record.setdefault("python", platform.python_version())
    print(json.dumps(record), flush=True)


def best_time(fn: Callable[[], Any], repeat: int = 7, number: int = 1, warmup: int = 1) -> float:
    """Smallest mean wall time of ``number`` calls over ``repeat`` rounds, in seconds."""
    for _ in range(warmup):
        fn()
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(number):
            fn()
        best = min(best, (time.perf_counter() - t0) / number)
    return best
