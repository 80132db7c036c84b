"""Benchmarks: functions that time parts of swarmgames and return plain dict records."""
