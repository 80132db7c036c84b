"""Benchmarks: ``swarmgames bench``. Performance targets live here, never in timed tests."""

from swarmgames.bench.timing import Timing, measure, peak_memory

__all__ = ["Timing", "measure", "peak_memory"]
