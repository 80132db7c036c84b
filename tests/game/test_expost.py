"""Ex-post regret: robot i's regret in hindsight, against the states its neighbours reached.

Definition (docs/game.md, "Ex-post regret"): robot i's true local game (actual states, the
true N_i(h), no virtual means; paper eq. 1 and section II.C, Fernando et al. 2022) with every
other member at the state it actually reached; the regret is the owner's best payoff over
its valid actions minus the payoff of the action it took.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from swarmgames.game import FunctionPotentials, StageProblem, make_solver, measure_stage, solve
from swarmgames.game.capabilities import PotentialCapabilities
from swarmgames.game.expost import expost_games, expost_regret
from swarmgames.game.local import broadcast
from swarmgames.game.stage import measure_expost
from tests.game.helpers import MODEL, POT, disk_snapshot, swarm

STAY = 0  # DisplacementActions.headings: action 0 is "stay"


class CrowdedGoal:
    """Potentials whose unary depends on the other members' states, as the coverage unary
    (eq. 5) does: a goal, minus a crowding term against the others' states."""

    goal = np.array([100.0, 100.0])
    capabilities = PotentialCapabilities()

    def unary(self, batch):
        nxt = np.asarray(batch.next_states)  # (B, K, A, D)
        st_ = np.asarray(batch.states)  # (B, K, D)
        mask = np.asarray(batch.mask)
        d = np.linalg.norm(nxt[:, :, :, None, :] - st_[:, None, None, :, :], axis=-1)
        k = mask.shape[1]
        others = mask[:, None, None, :] & ~np.eye(k, dtype=bool)[None, :, None, :]
        crowd = np.where(others, np.exp(-d / 15.0), 0.0).sum(axis=3)
        return -np.linalg.norm(nxt - self.goal, axis=-1) / 50.0 - 0.3 * crowd

    def pairwise(self, batch):
        nxt = np.asarray(batch.next_states)
        s_k = nxt[:, :, None, :, None, :]
        s_l = nxt[:, None, :, None, :, :]
        return -np.exp(-np.linalg.norm(s_k - s_l, axis=-1) / 20.0)


def _valid_random_actions(pos, seed):
    keys = np.random.default_rng(seed).random((pos.shape[0], MODEL.n_actions))
    return np.where(MODEL.valid(pos), keys, -1.0).argmax(axis=1)


def _next(pos, actions):
    return MODEL.apply(pos)[np.arange(pos.shape[0]), actions]


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 14), crowded=st.booleans())
def test_expost_regret_is_nonnegative_and_zero_for_the_best_hindsight_action(seed, n, crowded):
    pos, snap = swarm(n, seed % 1000)
    pot = CrowdedGoal() if crowded else POT
    solver = make_solver("mean_field", alpha_b=0.5)
    actions = _valid_random_actions(pos, seed)
    out = measure_expost(
        StageProblem.ideal(snap, 2, pos, MODEL, pot, solver), actions, _next(pos, actions)
    )
    assert out.shape == (n,) and np.all(out >= 0.0)
    # Robot 0 switching to its best action in hindsight has no regret left.
    games = expost_games(broadcast(snap, 2, pos).views([0]), _next(pos, actions), MODEL)
    pay = solver.evaluate(games, pot)
    field = pay.unary[0, 0] + (pay.pair_at(np.zeros((1, games.n_vars), int))[0, 0].sum(1))
    best = int(np.where(pay.action_mask[0, 0], field, -np.inf).argmax())
    hindsight = actions.copy()
    hindsight[0] = best
    assert expost_regret(pay, hindsight)[0] == 0.0


@pytest.mark.parametrize("crowded", [False, True])
def test_expost_equals_global_regret_when_every_neighbour_stands_still(crowded):
    # All robots take "stay": the states reached are the states, and the ex-post game is the
    # global regret's true game with every neighbour at its realised action.
    pos, snap = swarm(15, 2)
    pot = CrowdedGoal() if crowded else POT
    solver = make_solver("mean_field", alpha_b=0.5)
    still = np.full(15, STAY)
    out = measure_stage(StageProblem.ideal(snap, 2, pos, MODEL, pot, solver), still)
    np.testing.assert_array_equal(out.expost_regret, out.global_regret)
    assert (out.global_regret > 0).any()  # staying is not a NE here: the test is not vacuous


def test_expost_equals_global_regret_for_robots_whose_neighbours_stand_still():
    # Only robot i's neighbours must stand still; robot i itself may move.
    pos, snap = swarm(15, 4)
    solver = make_solver("mean_field", alpha_b=0.5)
    actions = np.full(15, STAY)
    movers = np.array([0, 7])
    actions[movers] = _valid_random_actions(pos, 1)[movers]
    out = measure_stage(StageProblem.ideal(snap, 2, pos, MODEL, CrowdedGoal(), solver), actions)
    messages = broadcast(snap, 2, pos)
    quiet = [i for i in range(15) if not set(messages.neighbourhood(i)) - {i} & set(movers)]
    assert quiet
    np.testing.assert_allclose(
        out.expost_regret[quiet], out.global_regret[quiet], rtol=0, atol=1e-12
    )


def _brute_force(pos, snap, h, actions, nxt, pot, alpha_a, alpha_b, owner):
    """M_i of eq. 1, summed term by term, over the owner's valid actions with every other
    member of N_i at its reached state; the best minus the action taken."""
    nbh = broadcast(snap, h, pos).neighbourhood(owner)
    members = [owner] + [int(j) for j in nbh if j != owner]
    states = np.array([pos[owner]] + [nxt[j] for j in members[1:]])
    valid = MODEL.valid(pos[owner : owner + 1])[0]
    moves = MODEL.apply(pos[owner : owner + 1])[0]
    payoffs = np.full(MODEL.n_actions, -np.inf)
    for a in np.flatnonzero(valid):
        where = states.copy()  # every variable's next state: the owner's after action a
        where[0] = moves[a]
        total = 0.0
        for k in range(len(members)):
            others = [states[m] for m in range(len(members)) if m != k]
            crowd = sum(np.exp(-np.linalg.norm(where[k] - o) / 15.0) for o in others)
            total += alpha_a * (-np.linalg.norm(where[k] - pot.goal) / 50.0 - 0.3 * crowd)
            for m in range(len(members)):
                if m != k:
                    total += alpha_b * -np.exp(-np.linalg.norm(where[k] - where[m]) / 20.0)
        payoffs[a] = total
    return payoffs.max() - payoffs[actions[owner]]


def test_expost_regret_against_brute_force_on_a_tiny_swarm():
    pos = np.array([[90.0, 95.0], [100.0, 110.0], [112.0, 98.0], [150.0, 150.0]])
    snap = disk_snapshot(pos, 30.0)
    actions = np.array([3, 5, 1, 0])
    nxt = _next(pos, actions)
    pot = CrowdedGoal()
    solver = make_solver("mean_field", alpha_a=1.0, alpha_b=0.5)
    out = measure_expost(StageProblem.ideal(snap, 2, pos, MODEL, pot, solver), actions, nxt)
    ref = [_brute_force(pos, snap, 2, actions, nxt, pot, 1.0, 0.5, i) for i in range(4)]
    np.testing.assert_allclose(out, ref, rtol=1e-12, atol=1e-12)
    assert (out > 0).any()


def test_solve_measures_expost_regret_with_the_global_regret():
    pos, snap = swarm(12, 5)
    solver = make_solver("mean_field", alpha_b=0.5)
    out = solve(StageProblem.ideal(snap, 2, pos, MODEL, CrowdedGoal(), solver), 0)
    ref = measure_expost(
        StageProblem.ideal(snap, 2, pos, MODEL, CrowdedGoal(), solver), out.actions, out.next_states
    )
    np.testing.assert_array_equal(out.expost_regret, ref)
    assert out.expost_s > 0
    off = solve(
        StageProblem.ideal(snap, 2, pos, MODEL, CrowdedGoal(), solver, global_regret=False), 0
    )
    assert np.isnan(off.expost_regret).all()
    with pytest.raises(ValueError, match=r"next_states must have shape \(12, 2\)"):
        measure_expost(
            StageProblem.ideal(snap, 2, pos, MODEL, POT, solver), out.actions, out.next_states[:3]
        )


def test_expost_regret_of_the_coverage_mission_equals_global_when_nobody_moves():
    # Every mission scores the ex-post games through its own potentials; the coverage unary
    # (eq. 5 with the windowed kernel, Inertia's move cost) and pairwise term (eq. 6 with
    # the crowding penalty) included.
    from swarmgames.config import resolve_scenario
    from swarmgames.sim.runner import build_mission

    cfg = resolve_scenario("coverage", ["swarm.n_robots=9"])
    mission = build_mission(cfg)
    states = mission.initial_states(9, np.random.default_rng(1))
    snap = disk_snapshot(states[:, :2], 368.84)
    solver = make_solver("mean_field", alpha_b=cfg.game.alpha_b)
    still = np.zeros(9, dtype=int)
    assert np.allclose(mission.action_model.apply(states)[np.arange(9), still], states)
    out = measure_stage(
        StageProblem.ideal(snap, 2, states, mission.action_model, mission.potentials, solver), still
    )
    np.testing.assert_allclose(out.expost_regret, out.global_regret, rtol=1e-9, atol=1e-9)
    assert np.all(out.expost_regret >= 0)


def test_function_potentials_without_a_pairwise_term():
    pos, snap = swarm(6, 0)
    pot = FunctionPotentials(lambda s: -np.linalg.norm(s - 100.0, axis=-1))
    solver = make_solver("mean_field")
    actions = _valid_random_actions(pos, 0)
    out = measure_stage(StageProblem.ideal(snap, 1, pos, MODEL, pot, solver), actions)
    # Without a pairwise term and with a unary of the own next state only, the neighbours'
    # states do not matter: ex-post and global regret agree whatever they did.
    np.testing.assert_array_equal(out.expost_regret, out.global_regret)
