"""Benchmarks: functions returning plain dict records (timing lives here, never in tests)."""
