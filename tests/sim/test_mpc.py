"""The receding-horizon controller (sim.controller = "mpc")."""

import pickle

import numpy as np
import pandas as pd
import pytest

from swarmgames.config import resolve_scenario
from swarmgames.errors import ConfigError
from swarmgames.sim import build_mission, resume, run
from swarmgames.sim.runner import build_loop

from .test_resume import StopAfter, assert_same_run

QUICK = ["sim.animation=false", "sim.duration_s=8.0", "sim.warmup_s=4.0", "swarm.n_robots=5"]
TIMINGS = ["solve_ms", "integrate_ms", "refine_ms"]


def _cfg(scenario="coverage", *extra):
    return resolve_scenario(scenario, [*QUICK, *extra])


@pytest.mark.parametrize("scenario", ["coverage", "rendezvous"])
def test_horizon_one_is_the_myopic_controller_bit_for_bit(scenario):
    game = run(_cfg(scenario), progress=False)
    mpc = run(_cfg(scenario, "sim.controller='mpc'", "sim.mpc_horizon=1"), progress=False)
    pd.testing.assert_frame_equal(game.trajectory, mpc.trajectory, check_exact=True)
    pd.testing.assert_frame_equal(
        game.metrics.drop(columns=TIMINGS), mpc.metrics.drop(columns=TIMINGS), check_exact=True
    )


def test_planning_leaves_the_loop_where_it_was_and_picks_the_best_candidate():
    cfg = _cfg("coverage", "sim.controller='mpc'", "sim.mpc_horizon=3", "sim.mpc_samples=2")
    mission = build_mission(cfg)
    states, loop, _ = build_loop(cfg, mission, None)
    loop.start(states)
    loop.step()
    before = pickle.dumps(loop.state())
    loop.controller.plan(loop)
    assert pickle.dumps(loop.state()) == before  # every prediction was undone
    scores = loop.controller.last_scores
    assert scores.size >= 2 and np.isfinite(scores).all()
    record = loop.step()  # plans again and executes the best candidate's first stage
    assert record.t == 5.0


def test_mpc_runs_are_reproducible_and_resumable(tmp_path):
    cfg = _cfg("rendezvous", "sim.controller='mpc'", "sim.mpc_horizon=2")
    run(cfg, out=tmp_path / "full", progress=False)
    again = run(cfg, progress=False)
    pd.testing.assert_frame_equal(
        again.trajectory, pd.read_csv(tmp_path / "full" / "trajectory.csv"), check_exact=True
    )
    out = tmp_path / "run"
    run(cfg, out=out, progress=False, mission=StopAfter(build_mission(cfg), 3))
    resume(out, progress=False, mission=build_mission(cfg))
    assert_same_run(out, tmp_path / "full")


def test_mpc_refuses_ns3():
    with pytest.raises(ConfigError, match="ns-3 cannot do"):
        resolve_scenario("coverage", ["sim.controller='mpc'", "network.backend='ns3'"])
    resolve_scenario("coverage", ["sim.controller='mpc'", "sim.mpc_horizon=1"])
