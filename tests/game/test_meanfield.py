"""Tests of the mean-field solver (paper Algorithm 1)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from swarmgames.game import evaluate_payoffs, local_regret, mean_field
from swarmgames.game.meanfield import masked_softmax
from tests.game.helpers import curie_weiss, random_games, trimmed_game

ENGINES = ["compiled", "blas", "sequential"]


def _solve(batch, pot, engine="blas", beta=3.0, delta=1e-9, max_iter=300, alpha_b=0.5):
    payoffs = evaluate_payoffs(batch, pot, 1.0, alpha_b)
    return payoffs, mean_field(payoffs, beta, delta, max_iter, engine=engine)


def test_two_variable_update_matches_hand_computation():
    # Algorithm 1 line 5 (init from the unary term) then one coordinate update of X_0 given
    # Q_1, with the payoff-maximising sign Q(x) ∝ exp(+β E[M | x]) (docs/reference.md section 1).
    batch, pot = random_games(3, 1, 2, 2, ragged=False)
    u = pot.unary_table[0]
    p = pot.pairwise_table[0]
    beta, ab = 0.7, 0.3
    payoffs = evaluate_payoffs(batch, pot, 1.0, ab)
    res = mean_field(payoffs, beta, delta=1e300, max_iter=1)  # stop after one sweep

    def softmax(v):
        e = np.exp(v - v.max())
        return e / e.sum()

    q1 = softmax(beta * u[1])
    f0 = u[0] + ab * np.array(
        [sum(q1[c] * (p[0, 1, a, c] + p[1, 0, c, a]) for c in range(2)) for a in range(2)]
    )
    q0 = softmax(beta * f0)
    f1 = u[1] + ab * np.array(
        [sum(q0[c] * (p[1, 0, a, c] + p[0, 1, c, a]) for c in range(2)) for a in range(2)]
    )
    np.testing.assert_allclose(res.marginals[0, 0], q0, rtol=1e-12)
    np.testing.assert_allclose(res.marginals[0, 1], softmax(beta * f1), rtol=1e-12)
    assert res.iterations[0] == 1 and res.converged[0]


def test_no_pairwise_term_converges_in_one_sweep_to_the_unary_softmax():
    batch, pot = random_games(1, 6, 4, 5, pairwise=False)
    payoffs, res = _solve(batch, pot, beta=2.0)
    expected = masked_softmax(2.0 * payoffs.unary, payoffs.action_mask)
    np.testing.assert_allclose(res.marginals, expected, rtol=1e-12, atol=0)
    assert np.all(res.iterations == 1) and np.all(res.converged) and np.all(res.kl == 0)


@pytest.mark.parametrize("engine", ENGINES)
def test_marginals_are_distributions_and_padding_gets_no_probability(engine):
    batch, pot = random_games(2, 20, 5, 6)
    _, res = _solve(batch, pot, engine)
    q = res.marginals
    assert np.all(np.isfinite(q))
    assert np.all(q[~batch.action_mask] == 0.0)
    np.testing.assert_allclose(q.sum(axis=2)[batch.mask], 1.0, rtol=1e-12)
    assert np.all(q.sum(axis=2)[~batch.mask] == 0.0)


@pytest.mark.parametrize("engine", ENGINES)
def test_kl_stopping_and_max_iter_are_honoured(engine):
    batch, pot = random_games(4, 30, 5, 4)
    delta = 1e-4
    _, res = _solve(batch, pot, engine, beta=4.0, delta=delta, max_iter=200)
    assert np.all(res.kl[res.converged] < delta)
    assert np.all(res.iterations >= 1) and np.all(res.iterations <= 200)
    # Capped runs stop at exactly max_iter and say whether the last sweep met delta.
    _, capped = _solve(batch, pot, engine, beta=4.0, delta=1e-14, max_iter=2)
    assert np.all(capped.iterations <= 2)
    stopped_early = capped.iterations < 2
    assert np.all(capped.converged[stopped_early])
    assert np.all(capped.converged == (capped.kl < 1e-14))
    assert not np.all(capped.converged)


def test_kl_reported_is_kl_of_the_last_sweep():
    # Re-running with max_iter = the iterations a game needed reproduces its result.
    batch, pot = random_games(5, 10, 4, 4)
    _, res = _solve(batch, pot, beta=2.0, delta=1e-6)
    for g in range(10):
        _, again = _solve(
            batch.select([g]),
            pot.select([g]),
            beta=2.0,
            delta=1e-6,
            max_iter=int(res.iterations[g]),
        )
        assert again.kl[0] == res.kl[g]
        np.testing.assert_array_equal(again.marginals[0], res.marginals[g])


@pytest.mark.parametrize("engine", ENGINES)
@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1), b=st.integers(1, 12), k=st.integers(1, 6), a=st.integers(1, 5)
)
def test_batched_equals_one_by_one_same_width(engine, seed, b, k, a):
    # A game's result must not depend on the other games of its batch: bitwise equality.
    batch, pot = random_games(seed, b, k, a)
    _, res = _solve(batch, pot, engine)
    for g in range(b):
        _, one = _solve(batch.select([g]), pot.select([g]), engine)
        np.testing.assert_array_equal(one.marginals[0], res.marginals[g])
        assert one.iterations[0] == res.iterations[g]
        assert one.converged[0] == res.converged[g]
        assert one.kl[0] == res.kl[g] or (np.isnan(one.kl[0]) and np.isnan(res.kl[g]))


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_games_stopping_at_many_sweeps_keep_their_results_through_compaction(engine, dtype):
    # The working set drops stopped games as they stop (a first copy, then rows moved within
    # it, out of order): every game must still get the bits it gets alone, and its own count.
    batch, pot = random_games(7, 40, 6, 4)
    payoffs = evaluate_payoffs(batch, pot, 1.0, 0.5, dtype=dtype)
    res = mean_field(payoffs, 4.0, 1e-7, 60, engine=engine)
    assert len(np.unique(res.iterations)) >= 5  # many stopping sweeps: compaction happens
    for g in range(40):
        one = mean_field(payoffs.select(slice(g, g + 1)), 4.0, 1e-7, 60, engine=engine)
        np.testing.assert_array_equal(one.marginals[0], res.marginals[g])
        assert one.iterations[0] == res.iterations[g]
        assert one.converged[0] == res.converged[g]
        assert one.kl[0] == res.kl[g]


@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1), b=st.integers(1, 10), k=st.integers(1, 7), a=st.integers(1, 5)
)
def test_batched_equals_one_by_one_without_padding_sequential(seed, b, k, a):
    # Sequential engine is bit-identical whatever the padded width (meanfield docstring).
    batch, pot = random_games(seed, b, k, a)
    _, res = _solve(batch, pot, "sequential")
    for g in range(b):
        one, one_pot = trimmed_game(batch, pot, g)
        _, alone = _solve(one, one_pot, "sequential")
        kk, aa = one.n_vars, one.n_actions
        np.testing.assert_array_equal(alone.marginals[0], res.marginals[g, :kk, :aa])
        assert alone.iterations[0] == res.iterations[g]
        assert alone.kl[0] == res.kl[g]


@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1), b=st.integers(1, 10), k=st.integers(1, 7), a=st.integers(1, 5)
)
def test_batched_equals_one_by_one_without_padding_blas(seed, b, k, a):
    # BLAS blocking depends on the padded length: equal to rounding (meanfield docstring).
    batch, pot = random_games(seed, b, k, a)
    _, res = _solve(batch, pot, "blas")
    for g in range(b):
        one, one_pot = trimmed_game(batch, pot, g)
        _, alone = _solve(one, one_pot, "blas")
        kk, aa = one.n_vars, one.n_actions
        np.testing.assert_allclose(
            alone.marginals[0], res.marginals[g, :kk, :aa], rtol=0, atol=1e-9
        )


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_low_temperature_profile_is_a_pure_nash_equilibrium(seed):
    # Issue acceptance: at large beta the argmax profile has local regret 0 in >= 95 % of
    # random small games (as beta -> inf the update is a best response, meanfield docstring).
    batch, pot = random_games(seed, 40, 5, 4)
    payoffs, res = _solve(batch, pot, beta=1e3, delta=1e-12, max_iter=500, alpha_b=1.0)
    profile = np.where(batch.action_mask, res.marginals, -1).argmax(axis=2)
    regret = local_regret(payoffs, profile)
    assert np.mean(regret <= 1e-9) >= 0.95


def test_isolated_robot_game_of_one_variable():
    batch, pot = random_games(7, 1, 1, 5, ragged=False)
    payoffs, res = _solve(batch, pot, beta=10.0)
    u = payoffs.unary[0, 0]
    np.testing.assert_allclose(res.marginals[0, 0], masked_softmax(10.0 * u, np.ones(5, bool)))
    assert res.converged[0] and res.iterations[0] == 1


def test_float32_tables_give_float32_marginals_close_to_float64():
    batch, pot = random_games(8, 15, 4, 5)
    p64 = evaluate_payoffs(batch, pot, 1.0, 0.5)
    p32 = evaluate_payoffs(batch, pot, 1.0, 0.5, dtype=np.float32)
    r64 = mean_field(p64, 2.0, 1e-6, 200)
    r32 = mean_field(p32, 2.0, 1e-6, 200)
    assert r32.marginals.dtype == np.float32
    np.testing.assert_allclose(r32.marginals, r64.marginals, atol=1e-3)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"beta": 0.0}, r"beta must be > 0 and finite \(got 0.0\)"),
        ({"beta": -1.0}, r"beta must be > 0"),
        ({"beta": np.inf}, r"beta must be > 0 and finite"),
        ({"delta": 0.0}, r"delta must be > 0 and finite \(got 0.0\)"),
        ({"delta": -1e-3}, r"delta must be > 0"),
        ({"max_iter": 0}, r"max_iter must be an integer >= 1 \(got 0\)"),
        ({"max_iter": 2.5}, r"max_iter must be an integer"),
        (
            {"engine": "fast"},
            r"engine must be one of 'auto', 'compiled', 'blas', 'sequential' \(got 'fast'\)",
        ),
    ],
)
def test_invalid_parameters_are_rejected(kwargs, match):
    batch, pot = random_games(0, 2, 2, 2)
    payoffs = evaluate_payoffs(batch, pot)
    args = {"beta": 1.0, "delta": 1e-6, "max_iter": 10, **kwargs}
    with pytest.raises(ValueError, match=match):
        mean_field(payoffs, **args)


@pytest.mark.parametrize("engine", ENGINES)
def test_empty_batch_gives_empty_results(engine):
    # A stage with no games of some size: nothing to solve, empty arrays of the right shapes.
    batch, pot = random_games(1, 3, 4, 3)
    payoffs = evaluate_payoffs(batch, pot, 1.0, 0.5).select(slice(0, 0))
    res = mean_field(payoffs, 3.0, 1e-6, 200, engine=engine)
    assert res.marginals.shape == (0, 4, 3)
    assert res.iterations.shape == res.converged.shape == res.kl.shape == (0,)


def _game_payoffs(logits, pair, action_mask=None, mask=None):
    from swarmgames.game.potentials import GamePayoffs

    b, k, a = logits.shape
    action_mask = np.ones((b, k, a), bool) if action_mask is None else action_mask
    mask = np.ones((b, k), dtype=bool) if mask is None else mask
    members = np.broadcast_to(np.arange(k, dtype=np.int32), (b, k))
    return GamePayoffs(logits, pair, action_mask, mask, np.zeros(b, np.int32), members)


@pytest.mark.parametrize("engine", ["blas", "sequential"])
def test_numpy_engines_sum_long_float32_fields_wide(monkeypatch, engine):
    """A four-level Curie-Weiss game of 256 spins (tests.game.helpers.curie_weiss, 1 024
    entries): the numpy engines, like the compiled one, sum its float32 pair fields in
    float64, and reach the fixed point of the same values in float64 (measured within
    2e-8, in the same sweeps). Summed in float32 the fields round to a few ulp of their
    constant term and the marginals stop 0.8-3e-4 away. A batch mixing it with small games
    solves each as alone."""
    from swarmgames.game import meanfield

    lg32, w32 = curie_weiss(256, coupling=1.4, levels=4)
    wide_pay = _game_payoffs(lg32, w32)
    f64 = mean_field(_game_payoffs(lg32.astype(float), w32.astype(float)), 1.0, engine=engine)
    wide = mean_field(wide_pay, 1.0, engine=engine)
    assert wide.marginals.dtype == np.float32
    assert abs(int(wide.iterations[0]) - int(f64.iterations[0])) <= 2
    np.testing.assert_allclose(wide.marginals, f64.marginals, atol=1e-6)
    # Small games in the same batch (padded to 600 variables): each is solved as alone.
    batch, pot = random_games(4, 3, 5, 4, ragged=False)
    small = evaluate_payoffs(batch, pot, 1.0, 1.0, dtype=np.float32)
    pad = ((0, 0), (0, 256 - 5))
    mixed = _game_payoffs(
        np.concatenate([lg32, np.pad(small.unary, (*pad, (0, 0)))]),
        np.concatenate([w32, np.pad(small.pair, (*pad, (0, 0), pad[1], (0, 0)))]),
        np.concatenate([wide_pay.action_mask, np.pad(small.action_mask, (*pad, (0, 0)))]),
        np.concatenate([wide_pay.mask, np.pad(small.mask, pad)]),
    )
    both = mean_field(mixed, 1.0, engine=engine)
    assert np.array_equal(both.marginals[:1], wide.marginals)
    assert np.array_equal(both.iterations[:1], wide.iterations)
    alone = mean_field(mixed.select([1, 2, 3]), 1.0, engine=engine)
    assert np.array_equal(both.marginals[1:], alone.marginals)
    monkeypatch.setattr(meanfield, "WIDE_SUM_MIN", 10**9)
    narrow = mean_field(wide_pay, 1.0, engine=engine)
    wide_err = np.abs(wide.marginals - f64.marginals).max()
    narrow_err = np.abs(narrow.marginals - f64.marginals).max()
    assert narrow_err > max(3e-5, 20 * wide_err)
