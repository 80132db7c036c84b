"""Smoke tests of the game benchmarks (records only; timings are never asserted)."""

from __future__ import annotations

import numpy as np

from swarmgames.bench.game import bench_local_game, pairwise_table_bytes, random_local_games


def test_bench_local_game_returns_a_complete_record():
    rec = bench_local_game(20, 3, 4, 0, n_single=5, repeats=1)
    for key in (
        "batched_per_game_ms",
        "single_per_game_ms",
        "speedup",
        "single_p99_ms",
        "iterations_mean",
        "converged_fraction",
        "pair_table_mb",
    ):
        assert key in rec and np.isfinite(rec[key])
    assert rec["n_games"] == 20 and 0.0 <= rec["converged_fraction"] <= 1.0


def test_pairwise_table_bytes_matches_the_array_size():
    # B K^2 A^2 values: 10 000 x 10^2 x 9^2 x 8 bytes = 648 000 000 bytes in float64.
    assert pairwise_table_bytes(10_000, 10, 9) == 648_000_000
    assert pairwise_table_bytes(10_000, 10, 9, np.float32) == 324_000_000
    _, pot = random_local_games(2, 3, 4)
    assert pot.pairwise_table.nbytes == pairwise_table_bytes(2, 3, 4)


def test_bench_stage_and_memory_records():
    from swarmgames.bench.game import bench_memory, bench_stage

    rec = bench_stage(30, 5.0, seed=1)
    assert rec["n_robots"] == 30 and rec["k_max"] >= 1 and rec["converged_fraction"] <= 1.0
    mem = bench_memory(50, 3, 4)
    assert mem["eval_peak_mb"] > 0 and mem["pair_table_mb"] == 50 * 9 * 16 * 8 / 2**20
