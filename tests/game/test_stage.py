"""Tests of one stage: games from the routing tables, solved, one action per robot."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from swarmgames.game import (
    MeanFieldSolver,
    StageProblem,
    evaluate_payoffs,
    global_regret,
    local_games,
    local_regret,
    make_solver,
    solve,
    stage_regret,
)
from swarmgames.game.capabilities import PotentialCapabilities
from swarmgames.game.stage import measure_stage
from tests.game.helpers import MODEL, POT, disk_snapshot
from tests.game.helpers import swarm as _swarm


def test_virtual_mean_switch_changes_the_games():
    pos, snap = _swarm(15, 1)
    solver = make_solver("mean_field")
    with_v = solve(StageProblem.ideal(snap, 1, pos, MODEL, POT, solver, keep_games=True))
    without = solve(
        StageProblem.ideal(snap, 1, pos, MODEL, POT, solver, virtual_mean=False, keep_games=True)
    )
    assert with_v.batch.is_virtual.any() and not without.batch.is_virtual.any()


class _Counting:
    """Potentials that count how many local games they evaluate."""

    capabilities = PotentialCapabilities()

    def __init__(self, inner):
        self.inner, self.games = inner, 0

    def unary(self, batch):
        self.games += batch.n_games
        return self.inner.unary(batch)

    def pairwise(self, batch):
        return self.inner.pairwise(batch)


@pytest.mark.parametrize("virtual_mean", [True, False, "eq3", "outside", "exact", "off"])
def test_global_regret_reuses_the_solved_tables(virtual_mean):
    # The true game of robot i is the solved game itself unless a member of N_i was replaced
    # by a virtual mean: only those games are evaluated a second time, and the result equals
    # rebuilding every true game (stage_regret, the reference). The ex-post games (the
    # others at their next states) are evaluated once more, every one of them.
    pos, snap = _swarm(15, 5)
    solver = make_solver("mean_field", alpha_b=0.5)
    pot = _Counting(POT)
    out = solve(StageProblem.ideal(snap, 2, pos, MODEL, pot, solver, virtual_mean=virtual_mean))
    virtual = local_games(snap, 2, pos, MODEL).is_virtual.any(axis=1)
    assert 0 < virtual.sum() < 15
    # A game with virtual means (eq3, outside) or context (exact: the games whose members
    # reach outside, the same ones) is not the true game; with "off" every game is.
    redo = int(virtual.sum()) if virtual_mean not in (False, "off") else 0
    assert pot.games == 15 + redo + 15
    ref = stage_regret(snap, 2, pos, MODEL, POT, out.actions, 1.0, 0.5)
    np.testing.assert_array_equal(out.global_regret, ref)
    skipped = solve(StageProblem.ideal(snap, 2, pos, MODEL, pot, solver, global_regret=False))
    assert np.isnan(skipped.global_regret).all()


def test_global_regret_when_an_action_is_invalid_at_a_virtual_position():
    """On the line 0 - 1 - 2 with h = 1, robot 1 reaches outside the games of 0 and 2 and sits
    there at its virtual mean (eq. 3), (9.9 + 2 + 9.9) / 3 = 7.27, where its own move to +x
    (valid at its real x = 2) would leave the box x <= 10. The global regret is measured on
    the true games all the same; robot 1's game (no virtual member) keeps its solved rows."""
    from swarmgames.game import DisplacementActions, FunctionPotentials
    from swarmgames.network import TopologySnapshot

    hops = np.array([[0, 1, 2], [1, 0, 1], [2, 1, 0]])
    snap = TopologySnapshot.from_hop_matrix(0.0, hops)
    pos = np.array([[9.9, 0.0], [2.0, 0.0], [9.9, 1.0]])
    model = DisplacementActions.headings(3.0, 4, lower=[-100.0, -100.0], upper=[10.0, 100.0])
    goal = FunctionPotentials(lambda s: s[..., 0])  # everyone wants +x
    solver = make_solver("mean_field", alpha_b=0.0)
    out = solve(StageProblem.ideal(snap, 1, pos, model, goal, solver, keep_games=True))
    assert out.batch.is_virtual[[0, 2]].any(axis=1).all() and not out.batch.is_virtual[1].any()
    assert out.actions[1] == 1  # +x, invalid at robot 1's virtual position
    virtual = out.batch.states[0, list(out.batch.members[0]).index(1)]
    assert not np.asarray(model.valid(virtual))[1]
    ref = stage_regret(snap, 1, pos, model, goal, out.actions, 1.0, 0.0)
    np.testing.assert_array_equal(out.global_regret, ref)


def test_global_regret_with_an_inbox_reevaluates_only_games_it_got_wrong():
    # With routed delivery, a robot's game is the true one when every member's state reached
    # it unchanged: those tables are reused, and only games holding a stale (here: shifted)
    # state are evaluated again; the result equals rebuilding every true game.
    from dataclasses import replace

    from swarmgames.game.local import broadcast

    pos, snap = _swarm(15, 5)
    solver = make_solver("mean_field", alpha_b=0.5)
    truth = broadcast(snap, 2, pos)
    stale = pos.copy()
    stale[3, :2] += 7.0  # robot 3's message is old: its reported position is off
    inbox = replace(truth, state=stale)
    wrong = np.array([3 in truth.neighbourhood(i) for i in range(15)])
    assert 0 < wrong.sum() < 15
    pot = _Counting(POT)
    out = solve(StageProblem(0.0, snap, 2, pos, inbox, MODEL, pot, solver, virtual_mean=False))
    assert pot.games == 15 + int(wrong.sum()) + 15  # and the 15 ex-post games
    ref = stage_regret(snap, 2, pos, MODEL, POT, out.actions, 1.0, 0.5)
    np.testing.assert_array_equal(out.global_regret, ref)


def test_exact_stage_solves_members_against_fixed_context():
    # virtual_mean = "exact": the context robots (∪_j N_j − N_i) sit in the game with one
    # action, all their probability on it; they are not counted as neighbours, and the
    # robot's payoff counts its members' terms (with the context) but not the context's own.
    pos, snap = _swarm(15, 5)
    solver = make_solver("mean_field", alpha_b=0.5)
    out = solve(
        StageProblem.ideal(snap, 2, pos, MODEL, POT, solver, virtual_mean="exact", keep_games=True)
    )
    batch, sol = out.batch, out.solution
    ctx = batch.is_context
    assert ctx.any() and not batch.is_virtual.any()
    np.testing.assert_array_equal(out.neighbours, batch.players.sum(axis=1) - 1)
    np.testing.assert_array_equal(
        out.neighbours, [snap.neighbourhood(i, 2).size - 1 for i in range(15)]
    )
    q = np.where(batch.action_mask, sol.marginals, 0.0)
    np.testing.assert_allclose(q[ctx].max(axis=1), 1.0)
    pay = solver.evaluate(batch, POT)
    profile = np.asarray(sol.profile)
    x = np.take_along_axis(pay.unary, profile[:, :, None], axis=2)[:, :, 0]
    w = np.take_along_axis(pay.pair_at(profile), profile[:, :, None, None], axis=2)[:, :, 0]
    counted = batch.players[:, :, None] | batch.players[:, None, :]
    want = np.where(batch.players, x, 0).sum(axis=1) + 0.5 * np.where(counted, w, 0).sum((1, 2))
    np.testing.assert_allclose(out.payoff, want, rtol=1e-12)
    assert np.all(out.local_regret >= 0)
    # Best-response refinement never moves a context robot off its one action, and reaches a
    # pure equilibrium of the members (game/refine.py).
    out = solve(
        StageProblem.ideal(
            snap,
            2,
            pos,
            MODEL,
            POT,
            solver,
            virtual_mean="exact",
            keep_games=True,
            refine="best_response",
        )
    )
    profile = np.asarray(out.solution.profile)[:, :, None]
    on = np.take_along_axis(out.batch.action_mask, profile, axis=2)[:, :, 0]
    assert on[out.batch.is_context].all() and np.all(out.local_regret == 0)


def test_measure_stage_scores_given_actions_on_the_true_games():
    pos, snap = _swarm(12, 6)
    solver = make_solver("mean_field", alpha_b=0.5)
    actions = np.random.default_rng(0).integers(0, MODEL.n_actions, 12)
    actions = np.where(MODEL.valid(pos)[np.arange(12), actions], actions, 0)
    out = measure_stage(StageProblem.ideal(snap, 1, pos, MODEL, POT, solver), actions)
    np.testing.assert_array_equal(out.actions, actions)
    ref = stage_regret(snap, 1, pos, MODEL, POT, actions, 1.0, 0.5)
    np.testing.assert_array_equal(out.global_regret, ref)
    assert np.all(out.local_regret >= out.global_regret)  # the owner is one of the players
    with pytest.raises(ValueError, match=r"actions must have shape \(12,\)"):
        measure_stage(StageProblem.ideal(snap, 1, pos, MODEL, POT, solver), actions[:3])


def test_low_temperature_stage_profiles_are_local_equilibria():
    pos, snap = _swarm(20, 2)
    solver = make_solver("mean_field", beta=1e4, delta=1e-12, max_iter=500, alpha_b=0.5)
    out = solve(StageProblem.ideal(snap, 2, pos, MODEL, POT, solver, keep_games=True))
    pay = solver.evaluate(out.batch, POT)
    regret = local_regret(pay, out.solution.profile)
    assert np.mean(regret <= 1e-9) >= 0.95
    np.testing.assert_array_equal(out.local_regret, regret)  # measured on the solved tables


def test_global_regret_of_a_stage_is_non_negative():
    pos, snap = _swarm(10, 3)
    true = evaluate_payoffs(local_games(snap, 1, pos, MODEL, virtual_mean=False), POT, 1.0, 0.5)
    out = solve(
        StageProblem.ideal(snap, 1, pos, MODEL, POT, make_solver("mean_field", alpha_b=0.5))
    )
    regret = global_regret(true, out.actions)
    np.testing.assert_array_equal(out.global_regret, regret)
    assert np.all(regret >= 0)
    np.testing.assert_array_equal(
        stage_regret(snap, 1, pos, MODEL, POT, out.actions, 1.0, 0.5), regret
    )


def test_isolated_robot_stage():
    pos = np.array([[10.0, 10.0], [190.0, 190.0]])
    snap = disk_snapshot(pos, 20.0)
    out = solve(
        StageProblem.ideal(snap, 2, pos, MODEL, POT, make_solver("mean_field"), keep_games=True)
    )
    assert out.batch.n_vars == 1 and out.solution.converged.all()
    # Each isolated robot moves towards (100, 100): heading 45 degrees for robot 0.
    assert out.actions[0] == 2 and out.actions[1] == 6


@pytest.mark.parametrize("engine", ["compiled", "sequential"])
@pytest.mark.parametrize("buckets", [2, 3, 50])
def test_buckets_give_the_same_stage_as_one_batch(buckets, engine):
    # The compiled and sequential engines are bit-identical whatever the padded width
    # (meanfield docstring).
    pos, snap = _swarm(25, 4)
    solver = MeanFieldSolver(alpha_b=0.5, beta=20.0, engine=engine)
    one = solve(StageProblem.ideal(snap, 2, pos, MODEL, POT, solver, keep_games=True))
    many = solve(
        StageProblem.ideal(snap, 2, pos, MODEL, POT, solver, buckets=buckets, keep_games=True)
    )
    np.testing.assert_array_equal(many.actions, one.actions)
    np.testing.assert_array_equal(many.batch.owner, np.arange(25))
    k = one.batch.n_vars
    np.testing.assert_array_equal(many.batch.members[:, :k], one.batch.members)
    np.testing.assert_array_equal(many.solution.marginals[:, :k], one.solution.marginals)
    np.testing.assert_array_equal(many.solution.iterations, one.solution.iterations)


def test_buckets_must_be_a_positive_integer():
    pos, snap = _swarm(3)
    with pytest.raises(ValueError, match=r"buckets must be an integer >= 0 \(got -1\)"):
        solve(StageProblem.ideal(snap, 2, pos, MODEL, POT, make_solver("mean_field"), buckets=-1))


def test_centralised_sampled_actions_are_valid_and_reproducible():
    pos, snap = _swarm(10, 5)
    solver = make_solver("mean_field", action_choice="sample", beta=1.0)
    a = solve(
        StageProblem.ideal(snap, 1, pos, MODEL, POT, solver, centralised=True, keep_games=True), 3
    )
    b = solve(StageProblem.ideal(snap, 1, pos, MODEL, POT, solver, centralised=True), 3)
    np.testing.assert_array_equal(a.actions, b.actions)
    assert np.all(MODEL.valid(pos)[np.arange(10), a.actions])
    # At beta = 1 the marginals are spread out: sampling differs from the argmax somewhere.
    assert np.any(a.actions != a.solution.profile[0])


@pytest.mark.parametrize("buckets", [0, 1, 3])
def test_size_groups_partition_the_robots_by_size(buckets):
    from swarmgames.game.stage import size_groups

    sizes = np.random.default_rng(0).integers(1, 30, size=500)
    groups = size_groups(sizes, buckets, 9, max_elems=2_000_000)
    assert np.array_equal(np.sort(np.concatenate(groups)), np.arange(500))
    # Groups in increasing size, each within the pairwise-table budget.
    assert all(sizes[a].max() <= sizes[b].min() for a, b in itertools.pairwise(groups))
    assert all(g.size * sizes[g].max() ** 2 * 81 <= 2_000_000 or g.size == 1 for g in groups)


def test_size_groups_keep_one_batch_for_a_small_swarm():
    from swarmgames.game.stage import size_groups

    groups = size_groups(np.array([3, 1, 2, 3]), 0, 9)
    assert len(groups) == 1 and np.array_equal(groups[0], np.arange(4))
