"""Tests of the baseline solvers: exact enumeration, best response, random."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from swarmgames.game import (
    best_response,
    evaluate_payoffs,
    exact_profiles,
    local_regret,
    profile_payoff,
    random_profiles,
)
from tests.game.helpers import random_games


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), k=st.integers(1, 4), a=st.integers(1, 4))
def test_exact_profile_maximises_payoff_and_is_an_equilibrium(seed, k, a):
    batch, pot = random_games(seed, 5, k, a)
    pay = evaluate_payoffs(batch, pot, 1.0, 1.0)
    x = exact_profiles(pay)
    assert np.all(local_regret(pay, x) <= 1e-9)
    best = profile_payoff(pay, x)
    for g in range(5):
        valid = [np.flatnonzero(pay.action_mask[g, v]) for v in np.flatnonzero(pay.mask[g])]
        for prof in itertools.product(*valid):
            y = np.zeros((1, k), dtype=int)
            y[0, : len(prof)] = prof
            assert profile_payoff(pay.select([g]), y)[0] <= best[g] + 1e-9


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_best_response_stops_at_a_pure_equilibrium(seed):
    # Monderer & Shapley (1996): best-response dynamics in a finite potential game stop at a
    # pure NE.
    batch, pot = random_games(seed, 20, 5, 4)
    pay = evaluate_payoffs(batch, pot, 1.0, 1.0)
    x, it, conv = best_response(pay, max_iter=500)
    assert conv.all() and np.all(it >= 1)
    assert np.all(local_regret(pay, x) == 0.0)


def test_best_response_honours_max_iter():
    batch, pot = random_games(1, 50, 6, 4)
    pay = evaluate_payoffs(batch, pot, 1.0, 5.0)
    _, it, conv = best_response(pay, max_iter=1)
    assert np.all(it == 1)
    assert not conv.all()  # one sweep is not enough for every one of 50 random games
    with pytest.raises(ValueError, match=r"max_iter must be an integer >= 1 \(got 0\)"):
        best_response(pay, max_iter=0)


def test_random_profiles_are_valid_and_reproducible():
    batch, pot = random_games(2, 30, 4, 5)
    pay = evaluate_payoffs(batch, pot)
    x = random_profiles(pay, np.random.default_rng(3))
    assert np.all(np.take_along_axis(pay.action_mask, x[:, :, None], 2)[:, :, 0][pay.mask])
    np.testing.assert_array_equal(x, random_profiles(pay, np.random.default_rng(3)))
    assert np.all(x[~pay.mask] == 0)
