"""Wall-clock timing with repeats and medians, and peak traced memory."""

from __future__ import annotations

import time
import tracemalloc
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["Timing", "measure", "peak_memory"]


@dataclass(frozen=True)
class Timing:
    """Repeated wall-clock measurements of one call.

    Attributes
    ----------
    samples : tuple of float
        Seconds of each timed repeat (warm-up calls excluded).
    """

    samples: tuple[float, ...]

    @property
    def median(self) -> float:
        """Median seconds per call."""
        return float(np.median(self.samples))

    @property
    def iqr(self) -> float:
        """Inter-quartile range of the samples, seconds."""
        q1, q3 = np.percentile(self.samples, [25, 75])
        return float(q3 - q1)

    def as_dict(self) -> dict[str, float]:
        return {"median_s": self.median, "iqr_s": self.iqr, "repeats": len(self.samples)}


def measure(fn: Callable[[], Any], repeat: int = 5, warmup: int = 1) -> Timing:
    """Time ``fn()`` ``repeat`` times after ``warmup`` untimed calls.

    Examples
    --------
    >>> t = measure(lambda: sum(range(100)), repeat=3)
    >>> len(t.samples), t.median >= 0
    (3, True)
    """
    if repeat < 1:
        raise ValueError(f"repeat must be >= 1 (got {repeat})")
    for _ in range(warmup):
        fn()
    samples = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        samples.append(time.perf_counter() - t0)
    return Timing(tuple(samples))


def peak_memory(fn: Callable[[], Any]) -> int:
    """Peak bytes allocated (Python and numpy, via tracemalloc) while ``fn()`` runs."""
    was_tracing = tracemalloc.is_tracing()
    if not was_tracing:
        tracemalloc.start()
    tracemalloc.reset_peak()
    base = tracemalloc.get_traced_memory()[0]
    try:
        fn()
        return int(tracemalloc.get_traced_memory()[1] - base)
    finally:
        if not was_tracing:
            tracemalloc.stop()
