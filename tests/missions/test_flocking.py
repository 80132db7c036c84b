"""Tests of the flocking mission: potentials against hand computations, metrics, runs."""

import math

import numpy as np
import pytest

from swarmgames.config import resolve_scenario
from swarmgames.errors import ConfigError
from swarmgames.game.batch import LocalGameBatch
from swarmgames.game.capabilities import PotentialCapabilities
from swarmgames.game.potentials import evaluate_payoffs
from swarmgames.missions import AccelerationActions, FlockingMission, check_mission, get_mission
from swarmgames.missions.flocking import FlockingPotentials, polarisation
from swarmgames.sim import run

# The authors' action set (docs/reference.md section 5): 25 labels, +-0.5 m/s^2, 1 m/s, 1 s.
MODEL = AccelerationActions(0.25, 2, 1.0, 1.0)
GOAL = (0.5, 0.0)


def _batch(states, mask, action_mask=None):
    states = np.asarray(states, dtype=float)
    mask = np.asarray(mask, dtype=bool)
    amask = MODEL.valid(states) & mask[..., None]
    if action_mask is not None:
        amask &= np.asarray(action_mask, dtype=bool)
    return LocalGameBatch(
        owner=np.zeros(mask.shape[0], dtype=np.int32),
        members=np.where(mask, np.arange(mask.shape[1]), -1),
        mask=mask,
        states=states,
        is_virtual=np.zeros(mask.shape, dtype=bool),
        next_states=MODEL.apply(states),
        action_mask=amask,
    )


def _mission(*overrides):
    config = resolve_scenario("flocking", [*overrides, "sim.animation=false"])
    return get_mission("flocking").build(config)


def test_builds_from_preset_and_conforms():
    mission = _mission()
    assert isinstance(mission, FlockingMission)
    assert mission.state_dim == 5 and mission.action_model.n_actions == 25
    assert mission.action_model.bounds is None
    check_mission(mission)
    check_mission(mission, n_robots=2, seed=3)


def test_unary_against_hand_computation():
    wc, wa, wg, wv = 1.0, 0.3, 0.2, 0.1
    pot = FlockingPotentials(GOAL, wc, wa, wg, accel_cost=wv)
    s = [
        [0.0, 0.0, 30.0, 0.2, 0.1],
        [6.0, 2.0, 30.0, -0.4, 0.3],
        [-3.0, 5.0, 30.0, 0.0, -0.5],
        [99.0, 99.0, 99.0, 9.0, 9.0],  # padding: never counts
    ]
    batch = _batch([s], [[True, True, True, False]])
    u = pot.unary(batch)
    nxt = batch.next_states[0]
    for k in range(3):
        others = [s[j] for j in range(3) if j != k]
        cx, cy, cz = (sum(o[c] for o in others) / 2 for c in range(3))
        mvx, mvy = (sum(o[c] for o in others) / 2 for c in (3, 4))
        for a in range(25):
            x, y, z, vx, vy = nxt[k, a]
            # hand: the robot's next position against the others' current centroid, its next
            # velocity against their mean velocity, the goal and its own current velocity
            hand = -(
                wc * math.dist((x, y, z), (cx, cy, cz))
                + wa * math.dist((vx, vy), (mvx, mvy))
                + wg * math.dist((vx, vy), GOAL)
                + wv * math.dist((vx, vy), s[k][3:5])
            )
            assert u[0, k, a] == pytest.approx(hand, rel=1e-12)
    assert np.all(u[0, 3] == 0.0)


def test_isolated_robot_keeps_only_the_goal_term():
    pot = FlockingPotentials(GOAL, 1.0, 1.0, 0.5)
    batch = _batch([[[4.0, -1.0, 30.0, 0.0, 0.0], [0.0] * 5]], [[True, False]])
    u = pot.unary(batch)[0, 0]
    v = batch.next_states[0, 0, :, 3:5]
    np.testing.assert_allclose(u, -0.5 * np.linalg.norm(v - GOAL, axis=1))
    assert int(np.argmax(u)) == int(np.flatnonzero((MODEL.accels == (0.5, 0.0)).all(1))[0])


def test_invalid_actions_and_padding_are_zero():
    pot = FlockingPotentials(GOAL, 1.0, 1.0, 1.0, separation_m=4.0, separation_weight=2.0)
    s = [[[0.0, 0.0, 30.0, 0.0, 0.0], [1.0, 0.0, 30.0, 0.0, 0.0], [0.0] * 5]]
    only = np.zeros((1, 3, 25), dtype=bool)
    only[0, :, :3] = True
    batch = _batch(s, [[True, True, False]], action_mask=only)
    u, p = pot.unary(batch), pot.pairwise(batch)
    assert np.all(u[0, :, 3:] == 0.0) and np.all(u[0, :2, :3] < 0.0)
    assert np.all(p[0, :, :, 3:, :] == 0.0) and np.all(p[0, :, :, :, 3:] == 0.0)
    assert np.all(p[0, 2] == 0.0) and np.all(p[0, :, 2] == 0.0)
    assert np.all(p[0, 0, 0] == 0.0)  # no self pair


def test_pairwise_against_hand_computation_and_alpha_b():
    ws, ds, alpha_b = 3.0, 4.0, 0.001
    pot = FlockingPotentials(GOAL, 0.0, 0.0, 0.0, ds, ws, alpha_b=alpha_b)
    s = [[[0.0, 0.0, 30.0, 0.5, 0.0], [2.0, 1.0, 30.0, -0.5, 0.0]]]
    batch = _batch(s, [[True, True]])
    p = pot.pairwise(batch)
    nxt = batch.next_states[0]
    for a in range(25):
        for c in range(25):
            d = math.dist(nxt[0, a, :3], nxt[1, c, :3])
            pen = max(0.0, 1.0 - d / ds) ** 2
            assert p[0, 0, 1, a, c] == pytest.approx(-ws / (2 * alpha_b) * pen, abs=1e-9)
            assert p[0, 1, 0, c, a] == pytest.approx(p[0, 0, 1, a, c], abs=1e-9)
    # In the engine's table a pair costs separation_weight * pen, whatever alpha_b.
    pay = evaluate_payoffs(batch, pot, alpha_b=alpha_b)
    d = np.linalg.norm(nxt[0, :, None, :3] - nxt[1, None, :, :3], axis=-1)
    np.testing.assert_allclose(pay.pair[0, 0, :, 1, :], -ws * np.maximum(0, 1 - d / ds) ** 2)


def test_pair_table_is_the_symmetrised_pairwise_term_bit_for_bit():
    # Three robots, two close (their blocks computed) and one far (left at 0), on a 4 m
    # separation; float64 tables equal the dense pairwise path exactly.
    pot = FlockingPotentials(GOAL, 1.0, 0.2, 0.2, 4.0, 10.0)
    s = [[[0.0, 0.0, 30.0, 0.5, 0.0], [3.0, 0.0, 30.0, 0.0, 0.3], [40.0, 0.0, 30.0, 0.0, 0.0]]]
    batch = _batch(s, [[True, True, True]])
    p = pot.pairwise(batch)
    dense = p.transpose(0, 1, 3, 2, 4) + p.transpose(0, 2, 4, 1, 3)
    table = pot.pair_table(batch)
    np.testing.assert_array_equal(table, dense)
    assert np.any(table[0, 0, :, 1, :] < 0) and not np.any(table[0, 0, :, 2, :])
    fast, slow = evaluate_payoffs(batch, pot), evaluate_payoffs(batch, _Dense(pot))
    np.testing.assert_array_equal(fast.pair, slow.pair)
    assert FlockingPotentials(GOAL, 1.0, 1.0, 1.0, 4.0, 0.0).pair_table(batch) is None


class _Dense:
    """The same potentials without pair_table (the engine's general path)."""

    capabilities = PotentialCapabilities()

    def __init__(self, pot):
        self.pot = pot

    def unary(self, batch):
        return self.pot.unary(batch)

    def pairwise(self, batch):
        return self.pot.pairwise(batch)


def test_pairwise_off_and_alpha_b_zero():
    assert FlockingPotentials(GOAL, 1.0, 1.0, 1.0, 4.0, 0.0).pairwise(None) is None
    with pytest.raises(ValueError, match="alpha_b"):
        FlockingPotentials(GOAL, 1.0, 1.0, 1.0, 4.0, 1.0, alpha_b=0.0)
    with pytest.raises(ConfigError, match=r"game\.alpha_b"):
        _mission("game.alpha_b=0.0")
    assert _mission("game.alpha_b=0.0", "flocking.separation_weight=0.0").potentials.alpha_b == 0


def test_headings_action_set_is_rejected():
    with pytest.raises(ConfigError, match=r"swarm\.action_set must be 'acceleration'"):
        _mission("swarm.action_set='headings'", "swarm.step_m=1.0")


def test_goal_faster_than_speed_limit_is_rejected():
    with pytest.raises(ConfigError, match=r"flocking\.goal_velocity_m_s"):
        _mission("flocking.goal_velocity_m_s=[1.0, 0.5]")
    with pytest.raises(ConfigError, match=r"flocking\.initial_speed_m_s"):
        _mission("flocking.initial_speed_m_s=2.0")


def test_polarisation_edge_cases():
    assert polarisation(np.zeros((3, 2))) == 0.0  # nobody moves
    assert polarisation(np.zeros((0, 2))) == 0.0
    assert polarisation(np.array([[0.3, 0.4]])) == pytest.approx(1.0)  # one robot
    assert polarisation(np.array([[1.0, 0.0], [0.0, 1.0]])) == pytest.approx(math.sqrt(0.5))


def test_swarm_metrics_by_hand():
    mission = _mission()
    s = np.array(
        [
            [0.0, 0.0, 30.0, 1.0, 0.0],
            [0.5, 0.0, 30.0, 1.0, 0.0],  # 0.5 m from robot 0: a near-collision
            [3.0, 0.0, 30.0, 0.0, 0.0],
            [1000.0, 0.0, 30.0, 0.0, 0.0],  # beyond radio range: a second component
        ]
    )
    got = mission.swarm_metrics(s, None, 0.0)
    centroid = s[:, :3].mean(axis=0)
    assert got["polarisation"] == pytest.approx(1.0)
    assert got["cohesion_radius_m"] == pytest.approx(np.linalg.norm(s[3, :3] - centroid))
    assert got["near_collisions"] == 1.0
    assert got["link_components"] == 2.0
    assert got["mean_speed_m_s"] == pytest.approx(0.5)
    np.testing.assert_allclose(mission.robot_metrics(s, 0.0)["speed_m_s"], [1.0, 1.0, 0.0, 0.0])


def test_summary_without_polarisation():
    mission = _mission()
    swarm = {"polarisation": np.array([0.2, 0.5]), "near_collisions": np.array([1.0, 2.0])}
    out = mission.summary(np.array([10.0, 11.0]), swarm)
    assert out["time_to_polarisation_s"] is None and out["near_collisions_total"] == 3
    assert out["cohesion_radius_end_m"] is None


def test_initial_velocities_seeded_and_bounded():
    mission = _mission("flocking.initial_speed_m_s=0.4")
    a = mission.initial_states(50, np.random.default_rng(1))
    b = mission.initial_states(50, np.random.default_rng(1))
    np.testing.assert_array_equal(a, b)
    speed = np.linalg.norm(a[:, 3:5], axis=1)
    assert speed.max() <= 0.4 and speed.min() >= 0.0 and np.ptp(speed) > 0.1
    at_rest = _mission("flocking.initial_speed_m_s=0.0").initial_states(
        50, np.random.default_rng(1)
    )
    np.testing.assert_array_equal(at_rest[:, :3], a[:, :3])  # same take-off positions
    assert np.all(at_rest[:, 3:] == 0.0)


SHORT = ["network.backend='oracle'", "sim.animation=false", "swarm.n_robots=6"]


def test_short_run_aligns_without_collisions():
    config = resolve_scenario("flocking", [*SHORT, "sim.duration_s=25.0", "seed=1"])
    result = run(config, out=None, progress=False)
    s = result.summary
    assert s["polarisation_end"] > s["polarisation_start"] + 0.3
    assert s["polarisation_end"] > 0.9 and s["time_to_polarisation_s"] is not None
    assert s["near_collisions_total"] == 0
    assert s["cohesion_radius_end_m"] < result.swarm["cohesion_radius_m"].iloc[0]
    assert (result.metrics["speed_m_s"] <= 1.0 + 1e-12).all()


def test_same_seed_same_trajectory():
    config = resolve_scenario("flocking", [*SHORT, "sim.duration_s=8.0", "seed=4"])
    a = run(config, out=None, progress=False).trajectory
    b = run(config, out=None, progress=False).trajectory
    assert a.equals(b)
    c = run(config.with_overrides({"seed": 5}), out=None, progress=False).trajectory
    assert not a.equals(c)
