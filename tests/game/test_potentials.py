"""Tests of the potentials and of the payoff tables of eq. 1."""

from __future__ import annotations

import numpy as np
import pytest

from swarmgames.game import (
    DisplacementActions,
    FunctionPotentials,
    LocalGameBatch,
    Potentials,
    TablePotentials,
    evaluate_payoffs,
    local_games,
    profile_payoff,
)
from swarmgames.game.capabilities import PotentialCapabilities
from tests.game.helpers import disk_snapshot, random_games


def test_tables_follow_eq1_weights_and_symmetrisation():
    # W[k, a, m2, c] = α_b (φ_p(k, a, m2, c) + φ_p(m2, c, k, a)) and U = α_a φ_u (module docs).
    batch, pot = random_games(0, 3, 4, 3, ragged=False)
    pay = evaluate_payoffs(batch, pot, 2.0, 0.25)
    u, p = pot.unary_table, pot.pairwise_table
    np.testing.assert_allclose(pay.unary, 2.0 * u)
    for k in range(4):
        for m2 in range(4):
            expect = 0.25 * (p[:, k, m2] + p[:, m2, k].transpose(0, 2, 1))
            if k == m2:
                expect = np.zeros_like(expect)
            np.testing.assert_allclose(pay.pair[:, k, :, m2, :], expect)


def test_profile_payoff_equals_eq1_by_hand():
    batch, pot = random_games(1, 4, 3, 3, ragged=False)
    pay = evaluate_payoffs(batch, pot, 1.0, 0.5)
    x = np.array([[0, 1, 2], [2, 2, 2], [1, 0, 1], [0, 0, 0]])
    for g in range(4):
        u, p = pot.unary_table[g], pot.pairwise_table[g]
        m = sum(u[k, x[g, k]] for k in range(3))
        m += 0.5 * sum(p[k, m2, x[g, k], x[g, m2]] for k in range(3) for m2 in range(3) if k != m2)
        np.testing.assert_allclose(profile_payoff(pay, x)[g], m, rtol=1e-12)


def test_padding_and_invalid_entries_are_zero_even_when_nan():
    batch, pot = random_games(2, 10, 5, 4)  # tables hold NaN at padding and invalid actions
    pay = evaluate_payoffs(batch, pot, 1.0, 1.0)
    assert np.all(np.isfinite(pay.unary)) and np.all(np.isfinite(pay.pair))
    assert np.all(pay.unary[~batch.action_mask] == 0)
    assert np.all(pay.pair.transpose(0, 1, 3, 2, 4)[~batch.valid_pairs()] == 0)


def test_asymmetric_pair_mask_counts_only_the_allowed_direction():
    batch, pot = random_games(3, 1, 2, 2, ragged=False)
    masked = LocalGameBatch(
        batch.owner,
        batch.members,
        batch.mask,
        batch.states,
        batch.is_virtual,
        batch.next_states,
        batch.action_mask,
        pair_mask=np.array([[[False, True], [False, False]]]),
    )
    pay = evaluate_payoffs(masked, pot, 1.0, 1.0)
    p = pot.pairwise_table[0]
    np.testing.assert_allclose(pay.pair[0, 0, :, 1, :], p[0, 1])
    np.testing.assert_allclose(pay.pair[0, 1, :, 0, :], p[0, 1].T)


def test_function_potentials_broadcast_over_every_pair_of_actions():
    pos = np.array([[0.0, 0.0], [10.0, 0.0], [20.0, 0.0]])
    batch = local_games(disk_snapshot(pos, 15.0), 1, pos, DisplacementActions.headings(1.0, 4))
    pot = FunctionPotentials(lambda s: s[..., 0], lambda a, b: np.linalg.norm(a - b, axis=-1))
    assert isinstance(pot, Potentials)
    u = pot.unary(batch)
    p = pot.pairwise(batch)
    assert u.shape == (3, 3, 5) and p.shape == (3, 3, 3, 5, 5)
    nxt = batch.next_states
    np.testing.assert_allclose(p[1, 0, 2, 3, 1], np.linalg.norm(nxt[1, 0, 3] - nxt[1, 2, 1]))


def test_non_finite_unary_names_robot_variable_and_action():
    batch, pot = random_games(4, 3, 3, 2, ragged=False)
    u = np.array(pot.unary_table)
    u[1, 2, 1] = np.inf
    with pytest.raises(
        ValueError,
        match=r"unary potential is not finite \(inf\) for local game "
        r"of robot 1 \(game 1\), variable 2 \(robot 102\), action 1",
    ):
        evaluate_payoffs(batch, TablePotentials(u, pot.pairwise_table))


def test_non_finite_pairwise_names_both_variables():
    batch, pot = random_games(5, 2, 3, 2, ragged=False)
    p = np.array(pot.pairwise_table)
    p[0, 0, 1, 1, 0] = np.nan
    with pytest.raises(
        ValueError,
        match=r"pairwise potential is not finite .* variable 0 "
        r"\(robot 100\), action 1, with variable 1 \(robot 101\), action 0",
    ):
        evaluate_payoffs(batch, TablePotentials(pot.unary_table, p), 1.0, 0.1)


def test_non_finite_pairwise_is_ignored_when_alpha_b_is_zero():
    batch, pot = random_games(5, 2, 3, 2, ragged=False)
    p = np.full_like(pot.pairwise_table, np.nan)
    assert evaluate_payoffs(batch, TablePotentials(pot.unary_table, p), 1.0, 0.0).pair is None


def test_empty_action_set_names_the_robot():
    batch, pot = random_games(6, 2, 3, 2, ragged=False)
    amask = np.array(batch.action_mask)
    amask[1, 2] = False
    bad = LocalGameBatch(
        batch.owner,
        batch.members,
        batch.mask,
        batch.states,
        batch.is_virtual,
        batch.next_states,
        amask,
    )
    with pytest.raises(
        ValueError,
        match=r"action set is empty for local game of robot 1 "
        r"\(game 1\), variable 2 \(robot 102\)",
    ):
        evaluate_payoffs(bad, pot)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"alpha_a": -1.0}, r"alpha_a must be >= 0 and finite \(got -1.0\)"),
        ({"alpha_b": np.nan}, r"alpha_b must be >= 0 and finite"),
        ({"dtype": np.int64}, r"dtype must be float64 or float32"),
    ],
)
def test_invalid_weights_and_dtype(kwargs, match):
    batch, pot = random_games(0, 1, 2, 2)
    with pytest.raises(ValueError, match=match):
        evaluate_payoffs(batch, pot, **kwargs)


def test_wrong_shapes_are_reported():
    batch, pot = random_games(0, 2, 2, 2, ragged=False)
    with pytest.raises(ValueError, match=r"unary potentials must have shape \(2, 2, 2\)"):
        evaluate_payoffs(batch, TablePotentials(np.zeros((2, 2, 3))))
    with pytest.raises(ValueError, match=r"pairwise potentials must have shape"):
        evaluate_payoffs(batch, TablePotentials(pot.unary_table, np.zeros((2, 2, 2, 2))))


class _Both:
    """Dense pairwise and the cheaper symmetrised table of the same φ_p."""

    capabilities = PotentialCapabilities(pair_table=True)

    def __init__(self, phi):
        self.phi = phi

    def unary(self, batch):
        return np.zeros(batch.action_mask.shape)

    def pairwise(self, batch):
        nxt = batch.next_states
        return self.phi(nxt[:, :, None, :, None, :], nxt[:, None, :, None, :, :])

    def pair_table(self, batch, dtype):
        nxt = batch.next_states
        a = nxt[:, :, :, None, None, :]
        b = nxt[:, None, None, :, :, :]
        return (self.phi(a, b) + self.phi(b, a)).astype(dtype)


class _DenseOnly(_Both):
    capabilities = PotentialCapabilities()  # its pair_table is not declared


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_pair_table_path_equals_the_dense_table(dtype):
    # An asymmetric φ_p checks the symmetrisation W = φ_p(k, a, l, c) + φ_p(l, c, k, a).
    phi = lambda s, t: -np.linalg.norm(s - t, axis=-1) + 0.1 * s[..., 0]  # noqa: E731
    pos = np.random.default_rng(1).uniform(0, 200, size=(15, 2))
    model = DisplacementActions.headings(5.0, 4)
    batch = local_games(disk_snapshot(pos, 70.0), 2, pos, model)
    a = evaluate_payoffs(batch, _Both(phi), 1.0, 0.3, dtype=dtype)
    b = evaluate_payoffs(batch, _DenseOnly(phi), 1.0, 0.3, dtype=dtype)
    np.testing.assert_allclose(a.pair, b.pair, rtol=1e-6 if dtype == np.float32 else 1e-13)
    assert a.pair.dtype == dtype


def test_pair_table_non_finite_names_the_robot():
    pos = np.random.default_rng(2).uniform(0, 100, size=(4, 2))
    model = DisplacementActions.headings(5.0, 4)
    batch = local_games(disk_snapshot(pos, 500.0), 1, pos, model)

    class Bad(_Both):
        def pair_table(self, batch, dtype):
            out = super().pair_table(batch, dtype)
            out[0, 0, 1, 1, 2] = np.nan
            return out

    with pytest.raises(ValueError, match=r"pairwise potential is not finite .* robot 0"):
        evaluate_payoffs(batch, Bad(lambda s, t: -np.linalg.norm(s - t, axis=-1)), 1.0, 0.1)
