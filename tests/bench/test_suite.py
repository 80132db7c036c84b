"""Smoke tests of the benchmark suite on tiny sizes (records only; timings never asserted)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from swarmgames.bench import BenchResult, run_suite
from swarmgames.bench.stage import StageBench


@pytest.fixture(scope="module")
def tiny():
    return run_suite(
        sizes=(5, 12),
        repeats=1,
        n_single=3,
        ns3=False,
        progress=False,
        takeoff=30,
        dense=True,
        mission=12,
        mission_stages=3,
        env=False,
    )


def test_records_of_every_benchmark(tiny):
    names = {r["benchmark"] for r in tiny.records}
    assert {"stage", "integrate", "local_game", "olsr_advance", "batched_vs_single"} <= names
    assert "batched_vs_single_random" in names
    assert "slope" in names
    comms = [r for r in tiny.records if r["benchmark"] == "routed_comms"]
    assert [r["n_robots"] for r in comms] == [5, 12] and all(r["share_of_stage"] > 0 for r in comms)
    stages = [r for r in tiny.records if r["benchmark"] == "stage"]
    assert [r["n_robots"] for r in stages] == [5, 12]
    for r in stages:
        assert r["median_s"] > 0 and r["peak_mb"] > 0
        assert r["integrate_s"] + r["solve_s"] + r["advance_s"] <= r["median_s"] * 1.5 + 1e-3
    for kind in ("batched_vs_single", "batched_vs_single_random"):
        by = {r["engine"]: r for r in tiny.records if r["benchmark"] == kind}
        assert set(by) == {"compiled", "blas"}  # Numba is a dependency
        for r in by.values():
            assert r["n_single"] == 3 and np.isfinite(r["ratio"]) and r["ratio"] > 0
        compiled, blas = by["compiled"], by["blas"]
        assert compiled["numpy_single_per_game_s"] == blas["single_per_game_s"]
        assert compiled["ratio_vs_numpy_single"] == pytest.approx(
            blas["single_per_game_s"] / compiled["batched_per_game_s"]
        )
    decide = next(r for r in tiny.records if r["benchmark"] == "decide_batched_vs_single")
    assert decide["n_games"] == 12 and decide["n_single"] == 3 and decide["ratio"] > 0
    assert tiny.meta["numba"]
    assert np.isfinite(tiny.slope)
    takeoff = {r["dense"]: r for r in tiny.records if r["benchmark"] == "takeoff"}
    assert set(takeoff) == {False, True}
    assert takeoff[True]["neighbours_mean"] == 29 and takeoff[True]["takeoff_radius_m"] == 25.0
    assert takeoff[False]["takeoff_radius_m"] > 25.0  # 30 UAVs: the disc grew
    for r in takeoff.values():
        assert r["n_robots"] == 30 and r["peak_mb"] > 0 and r["median_s"] > 0
        assert r["peak_mb"] <= r["estimate_mb"] <= r["estimate_network_mb"]
    assert tiny.meta["reuse_freed_memory"] in (True, False)
    (dense,) = [r for r in tiny.records if r["benchmark"] == "dense_stage"]
    assert dense["n_robots"] == 30 and dense["neighbours_mean"] == 29  # all within range
    assert dense["median_s"] > 0 and dense["peak_mb"] > 0 and dense["ratio_to_physical"] > 0
    assert "dense stage, N = 30" in tiny.table().caption


def test_whole_mission_record(tiny):
    (rec,) = [r for r in tiny.records if r["benchmark"] == "mission"]
    assert (rec["n_robots"], rec["stages"]) == (12, 3)
    assert 0 < rec["loop_s"] < rec["total_s"]
    assert rec["outputs_s"] == pytest.approx(rec["total_s"] - rec["loop_s"])
    assert rec["median_stage_s"] > 0 and rec["stage_vs_bench"] > 0
    assert rec["outputs_vs_loop"] == pytest.approx(rec["outputs_s"] / rec["loop_s"])
    assert {"animation.gif", "paths.png", "timeseries.png", "summary.json"} <= set(rec["files"])
    # The target is that of 1 000 UAVs: not reported for this one.
    assert not [r for r in tiny.records if r["benchmark"] == "target" and r["of"] == "mission"]


def test_quick_runs_no_whole_mission(monkeypatch):
    import swarmgames.bench.suite as suite

    def refuse(*args, **kwargs):
        raise AssertionError("--quick must not run the whole mission")

    monkeypatch.setattr(suite, "mission_record", refuse)
    result = run_suite(
        quick=True,
        sizes=(5,),
        repeats=1,
        n_single=2,
        ns3=False,
        progress=False,
        takeoff=0,
        env=False,
    )
    assert not [r for r in result.records if r["benchmark"] == "mission"]


def test_table_frame_plot_and_files(tiny, tmp_path):
    frame = tiny.to_frame()
    assert len(frame) == len(tiny.records) and "benchmark" in frame
    table = tiny.table()
    assert table.row_count == 2
    fig = tiny.plot()
    assert fig.axes[0].get_xscale() == "log" and fig.axes[0].get_yscale() == "log"
    assert any("slope" in t.get_text() for t in fig.axes[0].get_legend().get_texts())
    paths = tiny.write(tmp_path / "bench")
    assert sorted(p.name for p in paths) == ["bench.csv", "bench.json", "bench.png"]
    data = json.loads((tmp_path / "bench" / "bench.json").read_text())
    assert data["records"][0]["benchmark"] == "stage"


def test_stage_bench_moves_the_swarm():
    sb = StageBench(6, seed=1)
    before = sb.states.copy()
    for _ in range(3):
        sb.step()
    assert sb.states.shape == before.shape and len(sb.parts.advance_s) == 3
    assert sb.time == pytest.approx(sb.config.sim.warmup_s + 3.0)


def test_empty_result_and_bad_sizes():
    assert np.isnan(BenchResult().slope)
    with pytest.raises(ValueError, match="sizes must be robot counts >= 1"):
        run_suite(sizes=(0,), progress=False)


@pytest.mark.ns3
def test_olsr_vs_ns3_record():
    from swarmgames.bench.suite import _olsr_vs_ns3
    from swarmgames.network.ns3_import import ns3_available

    if not ns3_available():
        pytest.skip("ns-3 is not installed (pip install 'swarmgames[ns3]')")
    rec = _olsr_vs_ns3(8, 6.0, seed=0)
    assert rec["benchmark"] == "olsr_vs_ns3" and "skipped" not in rec
    assert rec["olsr_s"] > 0 and rec["ns3_s"] > 0
    assert 0.0 <= rec["route_agreement"] <= 1.0


@pytest.mark.parametrize(
    "overrides",
    [{"swarm.action_set": "acceleration", "coverage.move_cost_db": 0.0}, {"game.solver": "exact"}],
)
def test_stage_bench_runs_the_configured_mission_and_controller(overrides):
    # The benchmark steps the run's own mission and controller: velocity states for the
    # acceleration set (it once failed with "states must have 5 columns").
    from swarmgames.config import scaled_config

    cfg = scaled_config(6).with_overrides(overrides)
    sb = StageBench(6, config=cfg, seed=1)
    sb.step()
    assert sb.states.shape == (6, sb.mission.state_dim)
    assert len(sb.parts.decide_s) == 1


def test_targets_are_reported_pass_or_fail_never_asserted(tiny):
    from swarmgames.bench.suite import TARGETS, _targets

    recs = [
        {"benchmark": "stage", "n_robots": 100, "ratio_to_physical": 3.0, "peak_mb": 5.0},
        {"benchmark": "stage", "n_robots": 1_000, "ratio_to_physical": 1.2, "peak_mb": 50.0},
        {"benchmark": "stage", "n_robots": 10_000, "ratio_to_physical": 2.5, "peak_mb": 2000.0},
        {"benchmark": "routed_comms", "n_robots": 10, "share_of_stage": 0.3},
        {"benchmark": "routed_comms", "n_robots": 1_000, "share_of_stage": 0.05},
        {"benchmark": "slope", "n_robots": 1_000, "value": 1.0, "from_n": 100, "to_n": 1_000},
    ]
    got = {(r["target"], r["n_robots"]): r["met"] for r in _targets(recs)}
    assert got == {
        ("stage vs physical estimate", 1_000): True,  # N = 100 is below min_n
        ("stage vs physical estimate", 10_000): False,
        ("slope of stage time against N, N = 100 ... 1,000", 1_000): True,  # the sizes run
        ("peak memory at N = 10 000", 10_000): False,
        ("routed comms share of a stage", 1_000): True,  # N = 10 is below min_n
    }
    assert {t.benchmark for t in TARGETS} >= {"stage", "slope", "dense_stage", "routed_comms"}
    # Targets of time are ratios measured in the same run, never absolute times.
    assert all(t.unit != "s" for t in TARGETS)
    # The dense stage is the dense_stage record, not the default scenario's take-off ones.
    dense = [
        {"benchmark": "takeoff", "n_robots": 300, "dense": True, "median_s": 3.0, "peak_mb": 1},
        {"benchmark": "dense_stage", "n_robots": 300, "ratio_to_physical": 0.05, "peak_mb": 9},
    ]
    got = {r["target"]: (r["value"], r["met"]) for r in _targets(dense)}
    assert got == {
        "dense stage vs physical estimate": (0.05, True),
        "dense stage memory": (9.0, True),
    }
    slope = [r for r in tiny.records if r["benchmark"] == "target" and r["of"] == "slope"]
    assert len(slope) == 1 and slope[0]["met"] == (slope[0]["value"] <= 1.05)
    for r in (r for r in tiny.records if r["benchmark"] == "stage"):
        # The physical estimate: N K A G + N K² A² sweeps operations at 1 ns each.
        assert r["physical_ops"] > 0 and r["ratio_to_physical"] > 0 and r["first_stage_s"] > 0
    assert "vs est." in [c.header for c in tiny.table().columns]


def test_learning_throughput_records():
    pytest.importorskip("gymnasium", reason='pip install "swarmgames[env]"')
    from swarmgames.bench.env import env_records

    recs = env_records(quick=True, rounds=1, cases=((3, 2),))
    vs, single = recs
    assert vs["benchmark"] == "env_vs_mpe" and (vs["n_robots"], vs["num_envs"]) == (3, 2)
    shares = [v for k, v in vs.items() if k.startswith("share_")]
    assert sum(shares) == pytest.approx(1.0, abs=0.05) and vs["share_reward"] > 0
    if "mpe_agent_steps_per_s" in vs:  # mpe2 installed
        assert vs["mpe_per_swarmgames"] == pytest.approx(
            vs["mpe_agent_steps_per_s"] / vs["agent_steps_per_s"]
        )
    assert single["benchmark"] == "env_single" and single["measured_per_default"] > 0
