"""Benchmarks: ``swarmgames bench``. Performance targets live here, never in timed tests."""

from swarmgames.bench.suite import BenchResult, run_suite
from swarmgames.bench.timing import Timing, measure, peak_memory

__all__ = ["BenchResult", "Timing", "measure", "peak_memory", "run_suite"]
