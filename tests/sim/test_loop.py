"""Tests of the stage loop: one robot, a partitioned swarm, Ctrl-C, determinism."""

import numpy as np
import pandas as pd
import pytest

from swarmgames.config import parse_config
from swarmgames.missions import disc_states
from swarmgames.sim import build_mission, run, run_stages
from swarmgames.sim.controllers import GameController
from swarmgames.sim.loop import oscillation, swarm_graph_stats

from .conftest import DiskOracle


def _cfg(**sections):
    base = {"sim": {"duration_s": 8.0, "warmup_s": 2.0, "animation": False}}
    for key, val in sections.items():
        base.setdefault(key, {}).update(val) if isinstance(val, dict) else base.update({key: val})
    return parse_config(base)


def test_one_robot():
    cfg = _cfg(swarm={"n_robots": 1})
    res = run(cfg, progress=False, provider=DiskOracle())
    m = res.to_frame("metrics")
    assert len(m) == 8
    assert (m["neighbours"] == 0).all()
    assert (m["local_regret"] == 0).all()  # a one-variable game is solved exactly
    assert res.swarm["components"].eq(1).all()
    assert res.swarm["max_hops"].eq(0).all()
    assert res.swarm["coverage"].iloc[-1] > res.swarm["coverage"].iloc[0]


def test_partitioned_swarm():
    # A 50 m radio range leaves robots taking off 60 m apart with no link at all.
    cfg = _cfg(swarm={"n_robots": 4, "start_radius_m": 200.0})
    res = run(cfg, progress=False, provider=DiskOracle(radius=50.0))
    sw = res.to_frame()
    assert sw["components"].iloc[0] >= 2
    m = res.to_frame("metrics")
    isolated = m[m["neighbours"] == 0]
    assert len(isolated) > 0
    assert np.isfinite(m["payoff"]).all()
    assert (m["global_regret"] >= 0).all()


def test_graph_stats_of_partition():
    from swarmgames.topology import TopologySnapshot

    hops = np.array([[0, 1, 0, 0], [1, 0, 0, 0], [0, 0, 0, 1], [0, 0, 1, 0]])
    mean_h, max_h, comps, edges = swarm_graph_stats(TopologySnapshot.from_hop_matrix(0.0, hops))
    assert (mean_h, max_h, comps) == (1.0, 1, 2)
    assert edges.tolist() == [[0, 1], [2, 3]]


@pytest.mark.parametrize("backend", ["olsr", "test-disk"])
def test_same_seed_identical_run_and_other_seed_differs(backend):
    cfg = _cfg(seed=3, swarm={"start_radius_m": 200.0})

    def provider():
        return DiskOracle() if backend == "test-disk" else None

    a = run(cfg, progress=False, provider=provider())
    b = run(cfg, progress=False, provider=provider())
    for table in ("trajectory", "metrics"):
        cols = [c for c in a.to_frame(table).columns if not c.endswith("_ms")]
        assert a.to_frame(table)[cols].equals(b.to_frame(table)[cols])
    c = run(_cfg(seed=4, swarm={"start_radius_m": 200.0}), progress=False, provider=provider())
    assert not a.trajectory.equals(c.trajectory)


def test_mean_field_engines_fly_the_same_mission():
    # The engines agree to rounding (swarmgames.game.meanfield): at the default β = 50 the
    # robots' argmax actions, hence the trajectories, are the same. 12 UAVs over 2 hops, so
    # the compiled engine runs its parallel path (>= 8 games per batch) with virtual means.
    runs = {}
    for engine in ("compiled", "blas", "sequential"):
        cfg = _cfg(seed=2, swarm={"n_robots": 12, "start_radius_m": 300.0}, game={"engine": engine})
        assert cfg.game.engine == engine
        runs[engine] = run(cfg, progress=False, provider=DiskOracle(radius=250.0))
    ref = runs["blas"].trajectory
    assert runs["blas"].to_frame()["max_hops"].max() >= 2
    for engine in ("compiled", "sequential"):
        assert runs[engine].trajectory.equals(ref)


class _Interrupting:
    """Wraps a controller and raises KeyboardInterrupt in stage ``at``."""

    def __init__(self, inner, at):
        self.inner, self.at, self.calls = inner, at, 0
        self.hops = inner.hops
        self.plan, self.problem = inner.plan, inner.problem
        self.measure, self.expost_regret = inner.measure, inner.expost_regret

    def decide(self, problem, rng):
        self.calls += 1
        if self.calls > self.at:
            raise KeyboardInterrupt
        return self.inner.decide(problem, rng)


def test_ctrl_c_keeps_completed_stages():
    cfg = _cfg()
    mission = build_mission(cfg)
    rng = np.random.default_rng(0)
    pos = disc_states(5, (0.0, 0.0), 20.0, 30.0, rng)
    provider = DiskOracle()
    log = run_stages(
        provider=provider,
        controller=_Interrupting(GameController(cfg, mission), 3),
        mission=mission,
        states=pos,
        n_stages=10,
        period_s=1.0,
        warmup_s=2.0,
        rng=rng,
    )
    assert log.interrupted
    assert log.actions.shape == (3, 5)
    assert log.states.shape == (4, 5, 3)
    np.testing.assert_array_equal(log.times, [2.0, 3.0, 4.0])
    # the network was advanced to the warm-up end and then once per completed stage
    assert provider.calls == [2.0, 3.0, 4.0, 5.0]


def test_positions_follow_actions():
    cfg = _cfg()
    res = run(cfg, progress=False, provider=DiskOracle())
    tr = res.trajectory
    n = cfg.swarm.n_robots
    xy = tr[["x", "y"]].to_numpy().reshape(-1, n, 2)
    act = tr["action"].to_numpy().reshape(-1, n)[:-1]
    step = np.linalg.norm(np.diff(xy, axis=0), axis=-1)
    np.testing.assert_allclose(step[act == 0], 0.0)
    np.testing.assert_allclose(step[act > 0], cfg.swarm.step_m)
    assert (tr["z"] == cfg.swarm.altitude_m).all()


def test_start_positions_in_takeoff_disc():
    pos = disc_states(500, (10.0, -5.0), 25.0, 30.0, np.random.default_rng(1))
    r = np.hypot(pos[:, 0] - 10.0, pos[:, 1] + 5.0)
    assert r.max() <= 25.0
    assert r.mean() == pytest.approx(25.0 * 2 / 3, rel=0.05)  # uniform over the disc


@pytest.mark.parametrize("choice", ["argmax", "sample"])
def test_colocated_start_separates(choice):
    # Regression: robots that all take off from one point built the same local game, took
    # the same action at every stage (argmax) and never separated. The seeded tie-break
    # gives them distinct actions at the first stage; after that their games differ.
    cfg = _cfg(
        swarm={"n_robots": 3, "start_radius_m": 0.0},
        game={"action_choice": choice},
        sim={"duration_s": 12.0},
    )
    res = run(cfg, progress=False, provider=DiskOracle())
    xy = res.trajectory[["x", "y"]].to_numpy().reshape(-1, 3, 2)
    assert np.ptp(xy[0], axis=0).max() == 0  # all at one point
    for stage in xy[1:]:
        gaps = np.linalg.norm(stage[:, None] - stage[None], axis=-1)[np.triu_indices(3, 1)]
        assert gaps.min() > 1.0
    assert np.isfinite(res.metrics[["payoff", "local_regret", "global_regret"]]).all().all()
    again = run(cfg, progress=False, provider=DiskOracle())
    pd.testing.assert_frame_equal(again.trajectory, res.trajectory)  # seeded


def test_hop_stats_reach_beyond_hello_only_tables():
    # 7 robots in a line 300 m apart (range 368.84 m, docs/reference.md section 2): HELLO-only OLSR
    # tables hold at most 2 hops, but the swarm is 6 hops across; the paper's Fig. 1 averages
    # over every reachable pair: 2 * (6*1 + 5*2 + 4*3 + 3*4 + 2*5 + 1*6) / 42 = 8/3.
    from swarmgames.network.olsr.provider import OlsrProvider

    pos = np.column_stack([np.arange(7) * 300.0, np.zeros(7), np.zeros(7)])
    net = OlsrProvider(7, hello_only=True, seed=0)
    net.reset(pos)
    snap = net.advance(30.0, pos)
    assert snap.hops.max() == 2
    mean_h, max_h, comps, _ = swarm_graph_stats(snap)
    assert (max_h, comps) == (6, 1)
    assert mean_h == pytest.approx(8 / 3)


def test_oscillation_counts_robots_back_where_they_were():
    a, b = np.zeros((4, 3)), np.zeros((4, 3))
    b[:2, 0] = 10.0  # robots 0 and 1 left ...
    c = b.copy()
    c[0, 0] = 0.0  # ... robot 0 came back, robot 1 flew on from there; 2 and 3 stayed
    c[1, 0] = 20.0
    assert oscillation(a, b, c) == pytest.approx(0.25)
    assert oscillation(None, b, c) == 0.0
    assert oscillation(a, a, a) == 0.0  # staying is not oscillating


def test_two_cycle_swarm_reports_full_oscillation():
    # Two robots that swap between two points every stage: every stage after the first has
    # every robot back at its position of two stages before.
    class Swap:
        hops = 1

        def plan(self, loop):
            pass

        def problem(self, t, snapshot, states, messages, *, keep_games=False):
            return states

        def decide(self, states, rng):
            from swarmgames.game.stage import StageSolution

            n = states.shape[0]
            nxt = states.copy()
            nxt[:, 0] = np.where(states[:, 0] > 0, 0.0, 10.0)
            z = np.zeros(n)
            return StageSolution(
                np.zeros(n, np.int64),
                nxt,
                z,
                z,
                z,
                z.astype(np.int64),
                z.astype(np.int64),
                np.ones(n, bool),
            )

    cfg = _cfg()
    mission = build_mission(cfg)
    log = run_stages(
        provider=DiskOracle(),
        controller=Swap(),
        mission=mission,
        states=np.zeros((2, 3)),
        n_stages=5,
        period_s=1.0,
        warmup_s=0.0,
        rng=np.random.default_rng(0),
    )
    np.testing.assert_array_equal(log.swarm["oscillation"], [0.0, 1.0, 1.0, 1.0, 1.0])
