"""Tests of regret and exact pure Nash equilibria."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from swarmgames.game import (
    DisplacementActions,
    FunctionPotentials,
    LocalGameBatch,
    TablePotentials,
    deviation_gains,
    evaluate_payoffs,
    global_regret,
    local_games,
    local_regret,
    profile_payoff,
    pure_equilibria,
)
from swarmgames.game.capabilities import PairSourceCapabilities
from tests.game.helpers import disk_snapshot, random_games


def _two_player(u, p):
    b = LocalGameBatch(
        owner=[0],
        members=[[0, 1]],
        mask=[[True, True]],
        states=np.zeros((1, 2, 1)),
        is_virtual=[[False, False]],
        next_states=np.zeros((1, 2, 2, 1)),
        action_mask=np.ones((1, 2, 2), dtype=bool),
    )
    return evaluate_payoffs(b, TablePotentials(np.asarray(u)[None], np.asarray(p)[None]), 1.0, 1.0)


def test_coordination_game_has_two_pure_equilibria():
    # Pure coordination: both gain 1 when they match (φ_p(k,a,l,c) = [a == c] / 2 so that the
    # symmetrised W is [a == c]); no unary term. NE = (0, 0) and (1, 1) (Monderer & Shapley).
    p = np.zeros((2, 2, 2, 2))
    p[0, 1] = p[1, 0] = 0.5 * np.eye(2)
    pay = _two_player(np.zeros((2, 2)), p)
    assert sorted(map(tuple, pure_equilibria(pay, 0).tolist())) == [(0, 0), (1, 1)]
    np.testing.assert_allclose(local_regret(pay, [[0, 1]]), [1.0])
    np.testing.assert_allclose(deviation_gains(pay, [[0, 1]]), [[1.0, 1.0]])
    np.testing.assert_allclose(local_regret(pay, [[1, 1]]), [0.0])


def test_unary_only_game_equilibrium_is_each_argmax():
    u = np.array([[0.0, 2.0], [3.0, 1.0]])
    pay = _two_player(u, np.zeros((2, 2, 2, 2)))
    assert pure_equilibria(pay, 0).tolist() == [[1, 0]]
    np.testing.assert_allclose(deviation_gains(pay, [[0, 1]]), [[2.0, 2.0]])


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), k=st.integers(1, 4), a=st.integers(1, 4))
def test_enumerated_equilibria_have_zero_regret_and_others_positive(seed, k, a):
    batch, pot = random_games(seed, 4, k, a)
    pay = evaluate_payoffs(batch, pot, 1.0, 1.0)
    for g in range(4):
        eqs = pure_equilibria(pay, g)
        assert eqs.shape[0] >= 1  # a finite potential game always has one
        reg = local_regret(pay.select([g] * len(eqs)), eqs)
        assert np.all(reg <= 1e-9)
        # Every other profile of valid actions has a profitable deviation.
        valid = [np.flatnonzero(pay.action_mask[g, v]) for v in np.flatnonzero(pay.mask[g])]
        eq_set = {tuple(e[: len(valid)]) for e in eqs.tolist()}
        for prof in itertools.product(*valid):
            if prof not in eq_set:
                x = np.zeros((1, pay.shape[1]), dtype=int)
                x[0, : len(prof)] = prof
                assert local_regret(pay.select([g]), x)[0] > 0


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_regret_is_non_negative_and_payoff_gain_matches(seed):
    batch, pot = random_games(seed, 6, 4, 3)
    pay = evaluate_payoffs(batch, pot, 1.0, 0.7)
    rng = np.random.default_rng(seed)
    keys = np.where(pay.action_mask, rng.random(pay.action_mask.shape), -1)
    x = np.where(pay.mask, keys.argmax(axis=2), 0)
    gains = deviation_gains(pay, x)
    assert np.all(gains >= 0)
    # The gain of variable k equals the change of M when k alone switches (potential game).
    base = profile_payoff(pay, x)
    for k in range(4):
        best = np.zeros(6)
        for act in range(3):
            y = x.copy()
            y[:, k] = act
            ok = pay.action_mask[:, k, act]
            y[~ok, k] = x[~ok, k]
            best = np.maximum(best, profile_payoff(pay, y) - base)
        np.testing.assert_allclose(gains[:, k], best, atol=1e-9)


def test_global_regret_uses_true_neighbourhood_and_realised_actions():
    # Three robots on a line (0-1-2, h = 1). Unary: -|x| after the move. Robot 1 sees 0 and 2;
    # robots 0 and 2 see only 1. Each robot gains 1/100 by moving towards x = 0.
    pos = np.array([[0.0, 0.0], [10.0, 0.0], [20.0, 0.0]])
    snap = disk_snapshot(pos, 12.0)
    model = DisplacementActions(np.array([[0.0, 0.0], [1.0, 0.0], [-1.0, 0.0]]))
    pot = FunctionPotentials(lambda s: -np.abs(s[..., 0]) / 100.0)
    true = local_games(snap, 1, pos, model, virtual_mean=False)
    pay = evaluate_payoffs(true, pot, 1.0, 0.0)
    np.testing.assert_allclose(global_regret(pay, np.array([0, 0, 0])), [0.0, 0.01, 0.01])
    np.testing.assert_allclose(global_regret(pay, np.array([0, 2, 2])), [0.0, 0.0, 0.0])
    np.testing.assert_allclose(global_regret(pay, np.array([1, 2, 2])), [0.01, 0.0, 0.0])


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 8))
def test_global_regret_equals_brute_force_over_true_neighbourhoods(seed, n):
    # Robot i's stage payoff (eq. 1 over its true N_i, actual states) and its best gain by
    # deviating alone, computed directly from the definition.
    rng = np.random.default_rng(seed)
    pos = rng.uniform(0, 60, size=(n, 2))
    snap = disk_snapshot(pos, 25.0)
    model = DisplacementActions.headings(3.0, 4)
    phi_u = lambda s: -np.linalg.norm(s - 30.0, axis=-1)  # noqa: E731
    phi_p = lambda s, t: np.exp(-np.linalg.norm(s - t, axis=-1) / 10.0)  # noqa: E731
    pot = FunctionPotentials(phi_u, phi_p)
    ab = 0.3
    pay = evaluate_payoffs(local_games(snap, 2, pos, model, virtual_mean=False), pot, 1.0, ab)
    joint = rng.integers(0, model.n_actions, size=n)
    nxt = model.apply(pos)

    def payoff(i, acts):
        nb = snap.neighbourhood(i, 2)
        m = sum(phi_u(nxt[j, acts[j]]) for j in nb)
        m += ab * sum(phi_p(nxt[j, acts[j]], nxt[k, acts[k]]) for j in nb for k in nb if j != k)
        return m

    expected = []
    for i in range(n):
        base = payoff(i, joint)
        alts = []
        for a in range(model.n_actions):
            dev = joint.copy()
            dev[i] = a
            alts.append(payoff(i, dev) - base)
        expected.append(max(alts))
    np.testing.assert_allclose(global_regret(pay, joint), expected, atol=1e-9)


def test_global_regret_rejects_bad_input():
    batch, pot = random_games(0, 2, 2, 2, ragged=False)
    pay = evaluate_payoffs(batch, pot)
    with pytest.raises(ValueError, match=r"joint_actions must have shape \(N,\)"):
        global_regret(pay, np.zeros((2, 2), dtype=int))
    with pytest.raises(ValueError, match=r"joint_actions has 1 entries"):
        global_regret(pay, np.zeros(1, dtype=int))


def test_profile_with_invalid_action_is_rejected():
    batch, pot = random_games(0, 2, 2, 3)
    pay = evaluate_payoffs(batch, pot)
    bad = np.argwhere(~pay.action_mask & pay.mask[:, :, None])
    if bad.size == 0:
        pytest.skip("seed 0 gives no invalid action")  # pragma: no cover
    g, k, a = bad[0]
    x = np.zeros((2, 2), dtype=int)
    x[g, k] = a
    with pytest.raises(ValueError, match=rf"profile action {a} is not valid for variable {k}"):
        local_regret(pay, x)


def test_enumeration_refuses_huge_games():
    batch, pot = random_games(0, 1, 6, 4, ragged=False)
    pay = evaluate_payoffs(batch, pot)
    with pytest.raises(ValueError, match=r"4096 joint profiles, more than max_profiles=100"):
        pure_equilibria(pay, 0, max_profiles=100)


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_global_regret_from_the_owner_rows_is_the_same(dtype):
    # The stage keeps only OwnerPayoffs (row 0 of each table) until the joint action is
    # known; the regret must be that of the whole tables, bit for bit.
    from dataclasses import replace

    from swarmgames.game import OwnerPayoffs, evaluate_payoffs

    batch, pot = random_games(7, 40, 6, 5, ragged=False)
    batch = replace(batch, owner=np.asarray(batch.members)[:, 0])  # variable 0 owns the game
    pay = evaluate_payoffs(batch, pot, 1.0, 0.5, dtype=dtype)
    members = np.asarray(pay.members)
    joint = np.random.default_rng(1).integers(0, 5, members.max() + 1)
    rows = OwnerPayoffs.of(pay)
    assert rows.pair.shape == (40, 5, 6, 5)
    whole = deviation_gains(pay, np.where(pay.mask, joint[np.maximum(members, 0)], 0))[:, 0]
    np.testing.assert_array_equal(global_regret(rows, joint), whole)
    np.testing.assert_array_equal(global_regret(pay, joint), whole)


class _RowsSource:
    """A held table served as a pair source whose rows at a profile are laid out as the
    coverage source's: ``(B, K, K A)`` rows of each variable's profile point, viewed as
    (B, K, A, K)."""

    capabilities = PairSourceCapabilities()

    def __init__(self, w):
        self.w = w

    def at(self, profile):
        b, k, a = self.w.shape[:3]
        at_l = np.take_along_axis(self.w, profile[:, None, None, :, None], axis=4)[..., 0]
        rows = np.ascontiguousarray(at_l.transpose(0, 3, 1, 2)).reshape(b, k, k * a)
        return rows.reshape(b, k, k, a).transpose(0, 2, 3, 1)


@pytest.mark.parametrize("layout", ["held", "rows"])
@pytest.mark.parametrize("with_players", [False, True])
def test_profile_measures_equal_the_payoff_and_the_regret_alone(layout, with_players):
    """One evaluation of the pairwise rows at the profile serves both measurements, bit for
    bit, whether the rows come from a held table or from a source laid out by variable."""
    from swarmgames.game import profile_measures
    from swarmgames.game.potentials import GamePayoffs

    batch, pot = random_games(11, 24, 7, 5)
    pay = evaluate_payoffs(batch, pot, 1.0, 1.0)
    w = np.nan_to_num(pay.pair)
    if layout == "rows":
        pay = GamePayoffs(
            pay.unary, None, pay.action_mask, pay.mask, pay.owner, pay.members, _RowsSource(w)
        )
        strides = pay.pair_at(np.zeros((24, 7), np.int64)).strides
        assert strides[3] > strides[1]  # l outermost
    rng = np.random.default_rng(2)
    x = np.argmax(np.where(pay.action_mask, rng.random(pay.action_mask.shape), -1), axis=2)
    players = (rng.random((24, 7)) < 0.6) & pay.mask if with_players else None
    payoff, regret = profile_measures(pay, x, players)
    assert np.array_equal(payoff, profile_payoff(pay, x, players))
    assert np.array_equal(regret, local_regret(pay, x))
    held = evaluate_payoffs(batch, pot, 1.0, 1.0)
    np.testing.assert_allclose(payoff, profile_payoff(held, x, players), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(regret, local_regret(held, x), rtol=1e-12, atol=1e-12)
