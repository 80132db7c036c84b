"""Tests of the compiled mean-field engine (swarmgames.game.meanfield_compiled).

The reference is the numpy implementation of the same iteration (paper Algorithm 1, whose
update is checked by hand in test_meanfield.py): the engines must agree to rounding, and the
compiled one must keep its own promise of bit-identical results whatever the batch, the padded
number of variables, the order of the valid variables among the padding, and the threads.
"""

from __future__ import annotations

import sys
import threading

import numba
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from swarmgames.errors import BackendUnavailableError
from swarmgames.game import evaluate_payoffs, mean_field
from swarmgames.game.meanfield import compiled_available
from swarmgames.game.meanfield_compiled import PARALLEL_MIN_GAMES, POOL_LOCK, pool
from swarmgames.game.potentials import GamePayoffs
from swarmgames.game.solvers import MeanFieldSolver
from tests.game.helpers import curie_weiss, random_games


def _payoffs(seed, b, k, a, dtype=np.float64, alpha_b=0.5, **kw):
    batch, pot = random_games(seed, b, k, a, **kw)
    return evaluate_payoffs(batch, pot, 1.0, alpha_b, dtype=dtype)


def _same(x, y):
    np.testing.assert_array_equal(x.marginals, y.marginals)
    np.testing.assert_array_equal(x.iterations, y.iterations)
    np.testing.assert_array_equal(x.converged, y.converged)
    np.testing.assert_array_equal(x.kl, y.kl)


def _trim_vars(p: GamePayoffs, kk: int) -> GamePayoffs:
    """The same games with only the first ``kk`` variable slots (actions untouched)."""
    return GamePayoffs(
        p.unary[:, :kk],
        None if p.pair is None else p.pair[:, :kk, :, :kk],
        p.action_mask[:, :kk],
        p.mask[:, :kk],
        p.owner,
        p.members[:, :kk],
    )


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    b=st.integers(1, 30),
    k=st.integers(1, 7),
    a=st.integers(1, 6),
    beta=st.sampled_from([0.5, 3.0, 20.0]),
)
def test_compiled_agrees_with_the_numpy_engines(seed, b, k, a, beta):
    # Same iteration, other summation order: equal to rounding (meanfield docstring). A game
    # whose KL lands within rounding of delta may stop one sweep apart, so compare the games
    # that stop at the same sweep exactly and require that almost all do.
    p = _payoffs(seed, b, k, a)
    c = mean_field(p, beta, 1e-10, 400, engine="compiled")
    for engine in ("blas", "sequential"):
        r = mean_field(p, beta, 1e-10, 400, engine=engine)
        same = c.iterations == r.iterations
        np.testing.assert_allclose(c.marginals[same], r.marginals[same], rtol=0, atol=1e-9)
        np.testing.assert_allclose(c.marginals, r.marginals, rtol=0, atol=1e-6)
        assert same.mean() >= 0.8


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), b=st.integers(1, 12), k=st.integers(1, 7))
def test_compiled_is_bit_identical_whatever_the_padded_number_of_variables(seed, b, k):
    # Each game of a ragged batch against the same game cut to its own valid variables.
    p = _payoffs(seed, b, k, 5)
    res = mean_field(p, 4.0, 1e-9, 300, engine="compiled")
    for g in range(b):
        nv = int(p.mask[g].sum())
        alone = mean_field(_trim_vars(p.select([g]), nv), 4.0, 1e-9, 300, engine="compiled")
        np.testing.assert_array_equal(alone.marginals[0], res.marginals[g, :nv])
        assert alone.iterations[0] == res.iterations[g]
        assert alone.kl[0] == res.kl[g]


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_valid_variables_between_padding_slots_give_the_prefix_result(dtype):
    # Padding slots interleaved with the valid variables (a GamePayoffs built by hand): the
    # valid variables keep their relative (update) order, so the bits are those of the packed
    # game, scattered back to the slots.
    p = _payoffs(11, 20, 5, 4, dtype=dtype)
    ref = mean_field(p, 3.0, 1e-9, 300, engine="compiled")
    k = p.shape[1]
    rng = np.random.default_rng(0)
    slots = np.sort(rng.permutation(2 * k)[:k])  # where each original slot goes, in order
    wide = 2 * k

    def spread(x, axis):
        shape = list(x.shape)
        shape[axis] = wide
        out = np.zeros(shape, dtype=x.dtype)
        idx = [slice(None)] * x.ndim
        idx[axis] = slots
        out[tuple(idx)] = x
        return out

    pair = spread(spread(p.pair, 1), 3)
    spread_p = GamePayoffs(
        spread(p.unary, 1),
        pair,
        spread(p.action_mask, 1),
        spread(p.mask, 1),
        p.owner,
        spread(p.members, 1),
    )
    assert not (spread_p.mask == np.sort(spread_p.mask, axis=1)[:, ::-1]).all()
    res = mean_field(spread_p, 3.0, 1e-9, 300, engine="compiled")
    np.testing.assert_array_equal(res.marginals[:, slots], ref.marginals)
    np.testing.assert_array_equal(np.delete(res.marginals, slots, axis=1), 0)
    np.testing.assert_array_equal(res.iterations, ref.iterations)


def test_results_do_not_depend_on_the_number_of_threads():
    p = _payoffs(5, 64, 8, 9, dtype=np.float32, ragged=False)
    assert p.shape[0] >= PARALLEL_MIN_GAMES
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = mean_field(p, 50.0, 1e-6, 200, engine="compiled")
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        many = mean_field(p, 50.0, 1e-6, 200, engine="compiled")
    finally:
        numba.set_num_threads(before)
    _same(one, many)


def test_pool_runs_small_work_on_the_calling_thread_and_restores_the_count():
    before = numba.get_num_threads()
    with pool(False):
        assert numba.get_num_threads() == 1 and POOL_LOCK.locked()
    with pool(True, 1):
        assert numba.get_num_threads() == 1
    with pool():
        assert numba.get_num_threads() == before
    with pool(True, 10**6):  # at most the threads Numba started with
        assert numba.get_num_threads() == numba.config.NUMBA_NUM_THREADS
    with pytest.raises(RuntimeError), pool(False):
        raise RuntimeError
    assert numba.get_num_threads() == before and not POOL_LOCK.locked()


def test_concurrent_calls_from_python_threads_are_safe_and_equal():
    # The thread pool is entered by one caller at a time (a lock); results are unaffected.
    p = _payoffs(6, 3 * PARALLEL_MIN_GAMES, 6, 5)
    ref = mean_field(p, 5.0, 1e-9, 300, engine="compiled")
    out = [None] * 4

    def work(i):
        out[i] = mean_field(p, 5.0, 1e-9, 300, engine="compiled")

    threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for r in out:
        _same(r, ref)


def test_small_batches_on_the_calling_thread_equal_the_parallel_path():
    p = _payoffs(9, 2 * PARALLEL_MIN_GAMES, 6, 5)
    full = mean_field(p, 5.0, 1e-9, 300, engine="compiled")
    for g in range(0, p.shape[0], PARALLEL_MIN_GAMES // 2):
        part = mean_field(p.select(slice(g, g + 3)), 5.0, 1e-9, 300, engine="compiled")
        np.testing.assert_array_equal(part.marginals, full.marginals[g : g + 3])


def test_no_pairwise_term_is_the_unary_softmax_in_one_sweep():
    p = _payoffs(2, 10, 5, 4, pairwise=False)
    assert p.pair is None
    c = mean_field(p, 2.0, 1e-9, 50, engine="compiled")
    r = mean_field(p, 2.0, 1e-9, 50, engine="blas")
    np.testing.assert_allclose(c.marginals, r.marginals, rtol=1e-12, atol=0)
    assert np.all(c.iterations == 1) and np.all(c.converged) and np.all(c.kl == 0)


def test_max_iter_caps_the_sweeps_and_reports_not_converged():
    p = _payoffs(3, 10, 6, 5, ragged=False)
    res = mean_field(p, 8.0, 1e-300, 3, engine="compiled")
    assert np.all(res.iterations == 3)
    assert not res.converged.any()
    np.testing.assert_allclose(res.marginals.sum(axis=2), p.mask.astype(float), atol=1e-12)


def test_invalid_actions_and_padding_get_exactly_zero_probability():
    p = _payoffs(4, 25, 6, 5, dtype=np.float32)
    res = mean_field(p, 10.0, 1e-6, 200, engine="compiled")
    assert res.marginals.dtype == np.float32
    assert np.all(res.marginals[~p.action_mask] == 0)
    assert np.all(res.marginals[~p.mask] == 0)


def test_a_valid_variable_without_actions_is_rejected_by_every_engine():
    p = _payoffs(0, 3, 3, 3, ragged=False)
    amask = p.action_mask.copy()
    amask[1, 2] = False
    bad = GamePayoffs(p.unary, p.pair, amask, p.mask, p.owner, p.members)
    match = r"action set is empty for local game of robot 1 \(game 1\), variable 2"
    for engine in ("compiled", "blas", "sequential"):
        with pytest.raises(ValueError, match=match):
            mean_field(bad, 1.0, engine=engine)


def test_without_numba_auto_falls_back_to_blas_and_compiled_says_how_to_install(monkeypatch):
    p = _payoffs(1, 4, 3, 3)
    monkeypatch.setitem(sys.modules, "numba", None)  # import numba -> ImportError
    assert not compiled_available()
    np.testing.assert_array_equal(
        mean_field(p, 2.0, engine="auto").marginals, mean_field(p, 2.0, engine="blas").marginals
    )
    with pytest.raises(BackendUnavailableError, match=r"pip install numba"):
        mean_field(p, 2.0, engine="compiled")


def test_solver_rejects_an_unknown_engine():
    with pytest.raises(ValueError, match=r"engine must be one of .* \(got 'gpu'\)"):
        MeanFieldSolver(engine="gpu")


def test_long_float32_pair_fields_sum_in_float64_and_converge_as_float64_does():
    """A Curie-Weiss (mean-field Ising) game of 600 spins near its critical coupling
    (D. Koller and N. Friedman, Probabilistic Graphical Models, 2009, section 11.5), whose
    pair table carries a large constant term that cancels in every softmax but not in a
    float32 sum: summed in float32 the marginals dither around the fixed point, and how
    that shows depends on the CPU's vector width (the lanes of the sum): with AVX-512 the
    KL test takes three times the sweeps, with AVX2 it stops 2.5e-3 away from the fixed
    point. Summed wide they converge with the float64 table on either."""
    from swarmgames.game.meanfield_compiled import WIDE_SUM_MIN, solve_batch

    k = 600
    lg32, w32 = curie_weiss(k)
    nv = np.array([k])
    assert k * 2 >= WIDE_SUM_MIN
    # The reference: the same (float32) values solved in float64.
    f64 = solve_batch(lg32.astype(float), w32.astype(float), nv, 1.0, 1e-6, 200)
    wide = solve_batch(lg32, w32, nv, 1.0, 1e-6, 200)
    narrow = solve_batch(lg32, w32, nv, 1.0, 1e-6, 200, wide_min=10**9)
    assert abs(int(wide[1][0]) - int(f64[1][0])) <= 5
    narrow_err = np.abs(narrow[0] - f64[0]).max()
    wide_err = np.abs(wide[0] - f64[0]).max()
    assert narrow[1][0] >= 2 * wide[1][0] or narrow_err >= 5 * wide_err
    # Near the critical coupling the last sweeps move Q by less than a float32 step: the
    # float32 marginals agree with float64's to about 1e-4.
    np.testing.assert_allclose(wide[0], f64[0], atol=5e-4)
    assert wide[0].dtype == np.float32
