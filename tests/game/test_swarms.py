"""Several independent swarms as one stage problem (``StageProblem.swarms``): the stacked
snapshot and messages, a solve that equals each swarm's own, co-located robots tied only
within a swarm, each swarm's draws from its own Generator, and the profile payoffs."""

import numpy as np
import pytest

from swarmgames.game import MeanFieldSolver, StageProblem, make_solver
from swarmgames.game.colocated import colocated_groups
from swarmgames.game.local import Messages, broadcast
from swarmgames.game.stage import measure_stage, profile_payoffs, solve
from swarmgames.topology import TopologySnapshot
from tests.game.helpers import MODEL, POT, swarm


def _problem(snap, pos, solver, **kw):
    return StageProblem.ideal(snap, 2, pos, MODEL, POT, solver, global_regret=False, **kw)


def _stacked(parts, solver, **kw):
    snap = TopologySnapshot.concat([s for _, s in parts])
    pos = np.concatenate([p for p, _ in parts])
    return _problem(snap, pos, solver, swarms=len(parts), **kw)


def test_concatenated_snapshot_and_messages_are_block_diagonal():
    (p0, s0), (p1, s1) = swarm(6, 0), swarm(4, 1)
    snap = TopologySnapshot.concat([s0, s1])
    assert snap.n_robots == 10
    np.testing.assert_array_equal(snap.hop_matrix()[:6, :6], s0.hop_matrix())
    np.testing.assert_array_equal(snap.hop_matrix()[6:, 6:], s1.hop_matrix())
    assert (snap.hop_matrix()[:6, 6:] == -1).all()
    both = Messages.concat([broadcast(s0, 2, p0), broadcast(s1, 2, p1)])
    want = broadcast(snap, 2, np.concatenate([p0, p1]))
    for name in ("state", "indptr", "indices", "mean_state"):
        np.testing.assert_array_equal(getattr(both, name), getattr(want, name))
    with pytest.raises(ValueError, match="share one time"):
        TopologySnapshot.concat([s0, TopologySnapshot.from_hop_matrix(1.0, s1.hop_matrix())])


def test_a_stacked_solve_is_each_swarms_own():
    parts = [swarm(8, s) for s in (0, 1, 2)]
    solver = MeanFieldSolver()
    stacked = solve(_stacked(parts, solver), [np.random.default_rng(s) for s in range(3)])
    own = [solve(_problem(s, p, solver), np.random.default_rng(e)) for e, (p, s) in
           enumerate(parts)]  # fmt: skip
    np.testing.assert_array_equal(stacked.actions, np.concatenate([o.actions for o in own]))
    np.testing.assert_allclose(stacked.payoff, np.concatenate([o.payoff for o in own]))


def test_each_swarm_draws_from_its_own_generator():
    # A sampling solver: swarm 1's actions do not depend on swarm 0 or on how many swarms
    # share the stage.
    solver = make_solver("mean_field", action_choice="sample", beta=1.0)
    a, b, c = swarm(8, 0), swarm(8, 1), swarm(8, 5)
    one = solve(_stacked([a, b], solver), [np.random.default_rng(0), np.random.default_rng(7)])
    two = solve(_stacked([c, b], solver), [np.random.default_rng(3), np.random.default_rng(7)])
    alone = solve(_problem(b[1], b[0], solver), np.random.default_rng(7))
    np.testing.assert_array_equal(one.actions[8:], alone.actions)
    np.testing.assert_array_equal(two.actions[8:], alone.actions)


def test_colocated_robots_are_tied_within_a_swarm_only():
    states = np.zeros((4, 2))
    assert [g.tolist() for g in colocated_groups(states)] == [[0, 1, 2, 3]]
    groups = colocated_groups(states, swarm=np.array([0, 0, 1, 1]))
    assert [g.tolist() for g in groups] == [[0, 1], [2, 3]]
    # Two swarms taking off from the same point: each separates on its own.
    pos = np.full((3, 2), 50.0)
    snap = TopologySnapshot.from_hop_matrix(0.0, np.ones((3, 3)))
    solver = MeanFieldSolver()
    alone = solve(_problem(snap, pos, solver), np.random.default_rng(1))
    both = solve(
        _stacked([(pos, snap), (pos, snap)], solver),
        [np.random.default_rng(1), np.random.default_rng(1)],
    )
    np.testing.assert_array_equal(both.actions, np.tile(alone.actions, 2))
    assert len(set(alone.actions.tolist())) == 3


def test_swarms_are_checked():
    (p0, s0), (p1, s1) = swarm(6, 0), swarm(6, 1)
    joined = TopologySnapshot.from_hop_matrix(0.0, np.ones((12, 12)))
    pos = np.concatenate([p0, p1])
    with pytest.raises(ValueError, match="reaches robot 6 of another swarm of 6 robots"):
        _problem(joined, pos, MeanFieldSolver(), swarms=2)
    with pytest.raises(ValueError, match="swarms must be an integer >= 1 that divides"):
        _problem(TopologySnapshot.concat([s0, s1]), pos, MeanFieldSolver(), swarms=5)
    with pytest.raises(ValueError, match="one Generator per swarm"):
        solve(_stacked([(p0, s0), (p1, s1)], MeanFieldSolver()), [np.random.default_rng(0)])


def test_profile_payoffs_are_the_measured_payoffs():
    pos, snap = swarm(12, 3)
    problem = _problem(snap, pos, MeanFieldSolver())
    allowed = MODEL.valid(pos)
    actions = np.argmax(np.random.default_rng(0).random(allowed.shape) * allowed, axis=1)
    np.testing.assert_allclose(
        profile_payoffs(problem, actions), measure_stage(problem, actions, expost=False).payoff
    )
