"""Tests of the rendezvous mission: its potentials against hand computations, its metrics and
short runs."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from swarmgames.config import ScenarioConfig, resolve_scenario
from swarmgames.errors import ConfigError
from swarmgames.game.inertia import Inertia
from swarmgames.missions import HeadingActions, RendezvousMission, check_mission, get_mission
from swarmgames.missions.rendezvous import RendezvousPotentials
from swarmgames.network.parameters import RadioParameters
from swarmgames.sim import run

# docs/reference.md section 2 (ns-3 3.44 Friis defaults): Pr = Pt - 20 log10(4 pi d f / c),
# Pt = 16.0206 dBm, f = 5.15 GHz, c = 299 792 458 m/s, L = 1; threshold -82 dBm (368.84 m).
PT, F, C, PTH = 16.0206, 5.15e9, 299_792_458.0, -82.0


def _friis(d):
    return PT - 20.0 * math.log10(4.0 * math.pi * d * F / C)


def _batch(states, model):
    states = np.asarray(states, dtype=float)
    mask = np.ones(states.shape[:2], dtype=bool)
    return SimpleNamespace(
        mask=mask,
        states=states,
        next_states=model.apply(states),
        action_mask=model.valid(states) & mask[..., None],
        is_virtual=np.zeros_like(mask),
        members=np.arange(states.shape[1])[None].repeat(states.shape[0], 0),
    )


def _config(*overrides):
    return resolve_scenario("rendezvous", [*overrides])


def _quick(*overrides, seed=0):
    # 5 UAVs on a 300 m disc (2 hops), goal 300 m away, instant shortest-path network.
    return _config(
        "swarm.n_robots=5",
        "swarm.start_radius_m=300.0",
        "rendezvous.goal_m=[300.0, 0.0]",
        "sim.duration_s=60.0",
        "sim.animation=false",
        "sim.global_regret=false",
        "network.backend='oracle'",
        f"seed={seed}",
        *overrides,
    )


def test_registered_preset_conforms():
    cfg = _config()
    mission = get_mission("rendezvous").build(cfg)
    assert isinstance(mission, RendezvousMission)
    assert isinstance(mission.potentials, Inertia) and mission.potentials.cost == 5.0
    check_mission(mission)
    check_mission(mission, n_robots=7, seed=3)


def test_defaults_conform_without_move_cost_and_with_accelerations():
    for over in ({"rendezvous.move_cost": 0.0}, {"swarm.action_set": "acceleration"}):
        cfg = ScenarioConfig(scenario="rendezvous").with_overrides(over)
        check_mission(get_mission("rendezvous").build(cfg))


def test_unary_is_minus_goal_distance():
    pot = RendezvousPotentials((100.0, 50.0), goal_weight=2.0)
    model = HeadingActions(10.0, 4)
    batch = _batch([[[0.0, 50.0, 30.0], [100.0, 80.0, 30.0]]], model)
    u = pot.unary(batch)
    # actions: stay, +x, +y, -x, -y; the horizontal distance only (altitude is not in it)
    assert u[0, 0].tolist() == pytest.approx(
        [-200.0, -180.0, -2 * math.hypot(100, 10), -220.0, -2 * math.hypot(100, 10)]
    )
    assert u[0, 1].tolist() == pytest.approx(
        [-60.0, -2 * math.hypot(10, 30), -80.0, -2 * math.hypot(10, 30), -40.0]
    )


def test_pairwise_against_hand_computation():
    # Two linked robots 300 m apart along x: their next distance sets the shortfall.
    w, m, alpha_b = 50.0, 3.0, 0.001
    pot = RendezvousPotentials((0.0, 0.0), RadioParameters(), m, w, 1.0, alpha_b)
    model = HeadingActions(10.0, 4)
    s0, s1 = np.array([0.0, 0.0, 30.0]), np.array([300.0, 0.0, 30.0])
    batch = _batch([[s0, s1]], model)
    p = pot.pairwise(batch)
    assert p.shape == (1, 2, 2, 5, 5)
    for a in range(5):
        for c in range(5):
            d = float(np.linalg.norm(s0 + model.offsets[a] - s1 - model.offsets[c]))
            hand = -w / (2 * alpha_b) * max(0.0, PTH + m - _friis(d))
            assert p[0, 0, 1, a, c] == pytest.approx(hand, rel=1e-9, abs=1e-9)
            assert p[0, 1, 0, c, a] == pytest.approx(hand, rel=1e-9, abs=1e-9)
    # moving apart (robot 0 to -x, robot 1 to +x): 320 m, 20 log10(320 / 261.1) = 1.77 dB short
    assert p[0, 0, 1, 3, 1] == pytest.approx(-w / (2 * alpha_b) * (PTH + m - _friis(320.0)))
    assert np.all(p[0, 0, 0] == 0) and np.all(p[0, 1, 1] == 0)
    # pair_table: the same values, symmetrised, in the solver's layout
    table = pot.pair_table(batch)
    np.testing.assert_allclose(table, p.transpose(0, 1, 3, 2, 4) + p.transpose(0, 2, 4, 1, 3))


def test_linked_pair_within_margin_is_free_and_pays_below_it():
    pot = RendezvousPotentials((0.0, 0.0))
    model = HeadingActions(10.0, 4)
    # Friis: threshold + 3 dB is met up to 368.84 / 10^(3/20) = 261.1 m.
    batch = _batch([[[0.0, 0.0, 30.0], [250.0, 0.0, 30.0]]], model)
    p = pot.pairwise(batch)[0, 0, 1]
    assert p[0, 0] == 0.0  # both stay: 250 m
    assert p[1, 0] == 0.0  # closer: 240 m
    assert p[3, 1] < 0.0  # apart: 270 m, below the margin
    assert p[3, 1] == pytest.approx(-50.0 / 0.002 * (PTH + 3.0 - _friis(270.0)))


def test_unlinked_pairs_get_nothing():
    pot = RendezvousPotentials((0.0, 0.0))
    model = HeadingActions(10.0, 4)
    # 370 m apart: not linked now (range 368.84 m), although moving together would link them.
    batch = _batch([[[0.0, 0.0, 30.0], [370.0, 0.0, 30.0], [0.0, 5000.0, 30.0]]], model)
    p = pot.pairwise(batch)
    assert np.all(p == 0.0)
    assert np.all(pot.pair_table(batch) == 0.0)


def test_no_link_term_gives_no_pairwise():
    assert RendezvousPotentials((0.0, 0.0), link_weight=0.0).pairwise(None) is None


def test_link_term_needs_alpha_b():
    with pytest.raises(ConfigError, match="alpha_b"):
        get_mission("rendezvous").build(
            ScenarioConfig(scenario="rendezvous").with_overrides({"game.alpha_b": 0.0})
        )
    cfg = ScenarioConfig(scenario="rendezvous").with_overrides(
        {"game.alpha_b": 0.0, "rendezvous.link_weight": 0.0}
    )
    check_mission(get_mission("rendezvous").build(cfg))


def test_metrics_count_lost_links_and_components():
    mission = get_mission("rendezvous").build(_config("rendezvous.goal_m=[0.0, 0.0]"))
    before = np.array([[0.0, 0.0, 30.0], [300.0, 0.0, 30.0], [600.0, 0.0, 30.0]])
    after = np.array([[0.0, 0.0, 30.0], [300.0, 0.0, 30.0], [700.0, 0.0, 30.0]])
    first = mission.swarm_metrics(before, None, 0.0)
    assert first == {
        "goal_distance_m": pytest.approx(300.0),
        "max_goal_distance_m": 600.0,
        "links_lost": 0.0,
        "link_components": 1.0,
    }
    second = mission.swarm_metrics(after, before, 1.0)
    assert second["links_lost"] == 1.0 and second["link_components"] == 2.0
    np.testing.assert_allclose(mission.robot_metrics(after, 1.0)["goal_distance_m"], [0, 300, 700])
    out = mission.summary(
        np.array([10.0, 11.0, 12.0]),
        {
            "max_goal_distance_m": np.array([90.0, 20.0, 5.0]),
            "goal_distance_m": np.array([50.0, 10.0, 3.0]),
            "links_lost": np.array([0.0, 2.0, 1.0]),
        },
    )
    assert out == {"time_to_gather_s": 11.0, "total_links_lost": 3, "goal_distance_end_m": 3.0}


def test_short_run_gathers():
    res = run(_quick(), progress=False)
    sw = res.swarm
    assert sw["goal_distance_m"].iloc[-1] < 0.1 * sw["goal_distance_m"].iloc[0]
    assert res.summary["time_to_gather_s"] is not None
    assert res.summary["goal_distance_end_m"] < 25.0


@pytest.mark.parametrize("seed", [0, 1])
def test_link_term_loses_no_more_links(seed):
    with_link = run(_quick(seed=seed), progress=False).summary["total_links_lost"]
    without = run(_quick("rendezvous.link_weight=0", seed=seed), progress=False)
    assert with_link <= without.summary["total_links_lost"]


def test_same_seed_same_trajectory():
    a = run(_quick("sim.duration_s=20.0", seed=3), progress=False).trajectory
    b = run(_quick("sim.duration_s=20.0", seed=3), progress=False).trajectory
    assert np.array_equal(a.to_numpy(), b.to_numpy())
