"""The memory estimate (swarmgames.sim.memory) against measured peaks, and the refusal."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
from click.testing import CliRunner

from swarmgames.cli import cli
from swarmgames.config import resolve_scenario
from swarmgames.game.local import broadcast
from swarmgames.game.memory import stage_memory
from swarmgames.sim import run
from swarmgames.sim.controllers import make_controller
from swarmgames.sim.memory import (
    MemoryLimitError,
    check_memory,
    estimate_memory,
    neighbourhood_size,
)
from swarmgames.sim.providers import provider_from_config
from swarmgames.sim.runner import build_mission

DENSE = "swarm.start_max_neighbours=0"  # every robot within range of every other


def _stage_peak(config) -> tuple[float, int]:
    """Traced peak of one stage (after an untimed one) and the largest |N_i|."""
    mission = build_mission(config)
    rngs = [np.random.default_rng(s) for s in np.random.SeedSequence(0).spawn(3)]
    states = mission.initial_states(config.swarm.n_robots, rngs[0])
    provider = provider_from_config(config.network, config.swarm.n_robots, rngs[1])
    provider.reset(states[:, :3], 0.0)
    snapshot = provider.advance(config.sim.warmup_s, states[:, :3])
    controller = make_controller(config, mission)
    problem = controller.problem(
        0.0, snapshot, states, broadcast(snapshot, controller.hops, states)
    )
    controller.decide(problem, rngs[2])
    tracemalloc.start()
    try:
        stage = controller.decide(problem, rngs[2])
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    return float(peak), int(stage.neighbours.max()) + 1


@pytest.mark.slow
@pytest.mark.parametrize(
    ("overrides", "tight"),
    [
        ([], True),
        (["swarm.n_robots=40"], True),
        (["swarm.n_robots=80", DENSE], True),
        # float32 payoffs take the fused coverage kernel, which builds neither the unary's
        # working blocks nor the batch's pairwise table: the estimate (still counting them)
        # is a safe bound there, not a tight one.
        (["swarm.n_robots=80", DENSE, "game.dtype='float32'"], False),
        (["swarm.n_robots=60", DENSE, "game.solver='centralised'"], True),
        (["swarm.n_robots=60", DENSE, "sim.controller='lloyd'"], True),
    ],
)
def test_stage_estimate_bounds_the_measured_peak_within_a_factor_of_two(overrides, tight):
    config = resolve_scenario("coverage", overrides)
    peak, k = _stage_peak(config)
    est = estimate_memory(config, whole_run=False)
    assert est.n_vars == k  # the neighbourhood the estimate assumed is the one built
    assert peak <= est.total_bytes, (peak / 2**20, est.describe(8))
    assert est.total_bytes <= (2.0 if tight else 8.0) * peak, (peak / 2**20, est.describe(8))


def test_neighbourhood_size_of_the_take_off_disc_and_of_the_mission_region():
    assert neighbourhood_size(resolve_scenario("coverage", [])) == 7
    # 300 UAVs take off over a 1.4 km disc but end in the 612 m ROI: all within 2 hops.
    assert neighbourhood_size(resolve_scenario("coverage", ["swarm.n_robots=300"])) == 300
    # 1 000 take off from a 2.6 km disc, which 90 s at 10 m/s shrink to 1.7 km at most.
    assert neighbourhood_size(resolve_scenario("coverage", ["swarm.n_robots=1000"])) == 188
    longer = ["swarm.n_robots=1000", "sim.duration_s=1000.0"]
    assert neighbourhood_size(resolve_scenario("coverage", longer)) == 1000
    spread = resolve_scenario("coverage", ["swarm.n_robots=10000"])
    from swarmgames.config import scaled_config

    assert neighbourhood_size(scaled_config(10_000)) < 40 < neighbourhood_size(spread)


def test_dense_300_robot_stage_is_estimated_under_two_gib():
    # Regression: every batch's table was kept until the joint action was known (N K^2 A^2
    # values, 5 GB at 200 robots). Now one batch (3 games of K = 300) and the owner rows.
    est = stage_memory(300, 300, 9)
    assert est.batch_games == 3
    assert est.total_bytes < 2 * 2**30
    assert dict(est.parts)["owner rows kept for the global regret"] == 300 * 300 * 81 * 8


def test_a_run_that_cannot_fit_is_refused_naming_the_knobs():
    config = resolve_scenario(
        "coverage", ["swarm.n_robots=5000", DENSE, "sim.memory_limit_gib=1.0"]
    )
    with pytest.raises(MemoryLimitError, match=r"sim\.memory_limit_gib = 1 = 1 GiB") as info:
        check_memory(config)
    msg = str(info.value)
    for knob in (
        "swarm.n_robots (5000)",
        "network.hops (2)",
        "swarm.start_max_neighbours",
        "game.dtype = 'float32'",
        "K = 5000",
    ):
        assert knob in msg
    assert info.value.estimate.total_bytes > info.value.limit_bytes
    with pytest.raises(MemoryLimitError):
        run(config, progress=False)


def test_cli_run_and_config_check_refuse_with_exit_2_before_starting(tmp_path):
    runner = CliRunner()
    out = tmp_path / "run"
    res = runner.invoke(
        cli,
        [
            "run",
            "--out",
            str(out),
            "--set",
            "swarm.n_robots=5000",
            "--set",
            "sim.memory_limit_gib=1.0",
        ],
    )
    assert res.exit_code == 2, res.output
    assert "estimated peak memory must be <=" in res.output
    assert "Traceback" not in res.output
    assert not out.exists()
    scenario = tmp_path / "big.toml"
    scenario.write_text("[swarm]\nn_robots = 5000\n[sim]\nmemory_limit_gib = 1.0\n")
    res = runner.invoke(cli, ["config", "check", str(scenario)])
    assert res.exit_code == 2 and "swarm.n_robots (5000)" in res.output
    scenario.write_text("[swarm]\nn_robots = 7\n")
    res = runner.invoke(cli, ["config", "check", str(scenario)])
    assert res.exit_code == 0 and "estimated peak memory" in res.output


def test_the_default_limit_is_a_share_of_the_available_memory(monkeypatch):
    import swarmgames.sim.memory as memory

    config = resolve_scenario("coverage", [])
    monkeypatch.setattr(memory, "available_memory_bytes", lambda: 10 * 2**30)
    limit, how = memory.memory_limit_bytes(config)
    assert limit == pytest.approx(8 * 2**30) and "80%" in how
    monkeypatch.setattr(memory, "available_memory_bytes", lambda: None)
    assert memory.memory_limit_bytes(config)[0] == float("inf")


@pytest.mark.slow
def test_olsr_hello_round_peak_is_estimated_within_a_factor_of_two():
    # Every robot's 2-hop set holds K1^2 entries: in a clique a HELLO round builds N^3.
    from swarmgames.sim.memory import _OLSR_PEAK

    config = resolve_scenario("coverage", ["swarm.n_robots=100", DENSE])
    mission = build_mission(config)
    states = mission.initial_states(100, np.random.default_rng(0))
    provider = provider_from_config(config.network, 100, np.random.default_rng(1))
    tracemalloc.start()
    try:
        provider.reset(states[:, :3], 0.0)
        provider.advance(config.sim.warmup_s, states[:, :3])
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    estimate = _OLSR_PEAK * 100**3
    assert peak / 2 <= estimate <= 2 * peak, peak / 2**20
    parts = dict(estimate_memory(config, mission).parts)
    assert parts["network: OLSR tables"] == 16.0 * 100**3


@pytest.mark.slow
def test_exact_games_hold_2h_hops_and_the_estimate_counts_them():
    # game.virtual_mean = "exact": a game holds N_i and its context (the members'
    # neighbours), up to 2h hops, so the estimate takes K of 2h hops; it must still bound
    # the measured peak, and the largest game built must fit in the K it assumed.
    from swarmgames.config import scaled_config

    base = scaled_config(120, backend="oracle").with_overrides({"sim.warmup_s": 0.0})
    exact = base.with_overrides({"game.virtual_mean": "exact"})
    assert neighbourhood_size(exact) > neighbourhood_size(base)
    mission = build_mission(exact)
    rng = np.random.default_rng(0)
    states = mission.initial_states(120, rng)
    provider = provider_from_config(exact.network, 120, rng)
    provider.reset(states[:, :3], 0.0)
    snapshot = provider.advance(0.0, states[:, :3])
    controller = make_controller(exact, mission)
    messages = broadcast(snapshot, controller.hops, states)
    stage = controller.decide(
        controller.problem(0.0, snapshot, states, messages, keep_games=True), rng
    )
    biggest = int(stage.batch.mask.sum(axis=1).max())
    assert int(stage.neighbours.max()) + 1 < biggest <= neighbourhood_size(exact, mission)
    tracemalloc.start()
    try:
        controller.decide(controller.problem(0.0, snapshot, states, messages), rng)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak <= estimate_memory(exact, mission, whole_run=False).total_bytes
