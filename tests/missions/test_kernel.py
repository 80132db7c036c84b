"""The fused compiled coverage kernel against the numpy windowed integral."""

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from swarmgames.config import scaled_config
from swarmgames.missions import CoveragePotentials, GaussianROI, HeadingActions, SignalModel
from swarmgames.missions.coverage import kernel
from swarmgames.missions.coverage.kernel import (
    PARALLEL_MIN_ROWS,
    compiled_windowed_unary,
    exp_f32,
    log1p_f32,
    log_f32,
)
from swarmgames.missions.coverage.window import RoiRaster, windowed_unary
from tests.game.helpers import games_of

T0, L0, N_EXP = 16.0206, 46.6777, 3.0  # ns-3 log-distance defaults, docs/reference.md section 2
ROI = GaussianROI((0.0, 0.0), ((400.0**2, 0.0), (0.0, 300.0**2)), 0.95, 20.0)
SIGNAL = SignalModel(T0, L0, N_EXP, 1.0)
MODEL = HeadingActions(10.0, 8)
RASTER = RoiRaster.from_roi(ROI, 40)


def _games(rng, b, k, spread, z=30.0):
    states = np.c_[rng.uniform(-spread, spread, (b * k, 2)), np.full(b * k, z)]
    states = states.reshape(b, k, 3)
    mask = np.ones((b, k), dtype=bool)
    mask[:, 1:] = rng.random((b, k - 1)) < 0.8
    nxt = MODEL.apply(states)
    amask = MODEL.valid(states) & mask[..., None]
    return mask, amask, states, nxt


def _ulps(got, ref):
    """|got - ref| in units of the float32 spacing at the float64 reference."""
    return np.abs(got.astype(np.float64) - ref) / np.spacing(np.abs(ref).astype(np.float32))


def _vectorised(fn):
    from numba import njit

    @njit
    def apply(x):
        out = np.empty_like(x)
        for i in range(x.size):
            out[i] = fn(x[i])
        return out

    return apply


@pytest.mark.parametrize(
    ("fn", "ref", "lo", "hi", "max_ulp"),
    [
        (log_f32, np.log, 1.0, 1e5, 1.0),  # squared distances d0² .. d_F²
        (exp_f32, np.exp, -87.0, 0.0, 1.0),  # e^{-|u|}
        (log1p_f32, np.log1p, 0.0, 1.0, 3.0),
    ],
)
def test_float32_functions_within_a_few_ulp(fn, ref, lo, hi, max_ulp):
    # Reference: numpy in float64, rounded; Cephes' bounds (Moshier 1989) are 1 ulp.
    x = np.random.default_rng(0).uniform(lo, hi, 200_000).astype(np.float32)
    x[:3] = [lo, hi, (lo + hi) / 2]
    got = _vectorised(fn)(x)
    assert _ulps(got, ref(x.astype(np.float64))).max() <= max_ulp


def test_log1p_is_exact_for_tiny_arguments():
    x = np.array([0.0, 1e-30, 1e-10, 5e-8], dtype=np.float32)
    assert np.array_equal(_vectorised(log1p_f32)(x), x)


@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    floor=st.sampled_from([-110.0, -100.0, -95.0]),
    tau=st.sampled_from([0.0, 0.2, 1.0, 3.0]),
    spread=st.sampled_from([40.0, 200.0, 500.0]),
    k=st.integers(1, 9),
)
def test_compiled_equals_numpy_to_float32_rounding(seed, floor, tau, spread, k):
    rng = np.random.default_rng(seed)
    mask, amask, states, nxt = _games(rng, 6, k, spread)
    ref = windowed_unary(RASTER, SIGNAL, floor, mask, amask, states, nxt, softness_db=tau)
    got = compiled_windowed_unary(RASTER, SIGNAL, floor, mask, amask, states, nxt, softness_db=tau)
    scale = max(float(np.abs(ref).max()), 1e-12)
    # Both sum ~400 float32 terms: they agree to a few float32 ulps of the largest value.
    assert np.abs(got - ref).max() <= 2e-6 * scale
    assert np.all(got[~amask] == 0.0)
    # The same best action of every variable unless two actions tie to float32 rounding.
    for b, v in zip(*np.nonzero(mask), strict=True):
        acts = np.flatnonzero(amask[b, v])
        best = acts[np.argmax(got[b, v, acts])]
        assert ref[b, v, acts].max() - ref[b, v, best] <= 4e-6 * scale


def test_compiled_is_bit_identical_on_any_thread_count():
    mask, amask, states, nxt = _games(np.random.default_rng(3), 40, 8, 400.0)
    runs = [
        compiled_windowed_unary(
            RASTER, SIGNAL, -100.0, mask, amask, states, nxt, softness_db=1.0, workers=w
        )
        for w in (1, 2, 1)
    ]
    assert np.array_equal(runs[0], runs[1]) and np.array_equal(runs[0], runs[2])


def test_a_few_games_on_the_calling_thread_give_the_pools_bits(monkeypatch):
    # Fewer variables than PARALLEL_MIN_ROWS (a UAV deciding alone) run on the calling
    # thread; forced onto the pool, the same games give the same values.
    mask, amask, states, nxt = _games(np.random.default_rng(6), 3, 8, 300.0)
    assert mask.sum() < PARALLEL_MIN_ROWS
    args = (RASTER, SIGNAL, -100.0, mask, amask, states, nxt)
    serial = compiled_windowed_unary(*args, softness_db=1.0, workers=2)
    monkeypatch.setattr(kernel, "PARALLEL_MIN_ROWS", 0)
    pooled = compiled_windowed_unary(*args, softness_db=1.0, workers=2)
    assert np.array_equal(serial, pooled) and np.abs(serial).max() > 0


@pytest.mark.parametrize("fn", [compiled_windowed_unary, windowed_unary])
def test_shared_states_give_the_same_bits_and_differing_beliefs_are_not_shared(fn):
    mask, amask, states, nxt = _games(np.random.default_rng(5), 30, 6, 300.0)
    # Game 1 holds game 0's members; its view of variable 2 is older (another position).
    states[1], nxt[1], mask[1], amask[1] = states[0], nxt[0], mask[0], amask[0]
    mask[:, 2] = True
    states[1, 2, :2] += 15.0
    nxt[1, 2] = MODEL.apply(states[1, 2][None])[0]
    amask[:, 2] = MODEL.valid(states[:, 2])
    ids = np.arange(30 * 6).reshape(30, 6)
    ids[1] = ids[0]  # the same members, as 2 * member + is_virtual would say
    args = (RASTER, SIGNAL, -100.0, mask, amask, states, nxt)
    alone = fn(*args, softness_db=1.0)
    shared = fn(*args, softness_db=1.0, state_ids=ids, chunk_elems=10**4)
    assert np.array_equal(alone, shared)


def test_chunks_of_distinct_states_give_the_same_bits_at_any_size():
    # Games sharing members (ids repeated across games): a state is computed once a chunk,
    # whatever the chunks, so every chunk size gives the same bits.
    rng = np.random.default_rng(11)
    mask, amask, states, nxt = _games(rng, 24, 7, 250.0)
    ids = rng.integers(0, 40, (24, 7))
    for b in range(1, 24):  # a member seen by two games is in the same state in both
        prev = np.flatnonzero(np.isin(ids[b], ids[:b]))
        for k in prev:
            b0, k0 = np.argwhere(ids[:b] == ids[b, k])[0]
            states[b, k], nxt[b, k], amask[b, k] = states[b0, k0], nxt[b0, k0], amask[b0, k0]
    ids[:, 0] = 100 + np.arange(24)  # each game's owner appears once
    args = (RASTER, SIGNAL, -100.0, mask, amask, states, nxt)
    alone = compiled_windowed_unary(*args, softness_db=1.0)
    for elems in (1, 10**4, 10**5, 10**8):
        shared = compiled_windowed_unary(*args, softness_db=1.0, state_ids=ids, chunk_elems=elems)
        assert np.array_equal(alone, shared)


def test_state_chunks_hold_whole_games_and_at_most_cap_states():
    from swarmgames.missions.coverage.kernel import _state_chunks

    rng = np.random.default_rng(2)
    row_game = np.repeat(np.arange(30), rng.integers(1, 6, 30))
    slot = rng.integers(0, 25, row_game.size)
    for cap in (5, 9, 40):
        start, local, src, src_start = _state_chunks(row_game, slot, 25, cap)
        assert start[0] == 0 and start[-1] == row_game.size and np.all(np.diff(start) > 0)
        for c in range(start.size - 1):
            lo, hi = start[c], start[c + 1]
            assert lo == 0 or row_game[lo] != row_game[lo - 1]  # whole games
            defs = src[src_start[c] : src_start[c + 1]]
            assert defs.size <= cap and np.unique(slot[defs]).size == defs.size
            # every row reads the entry of its own slot
            assert np.array_equal(slot[defs][local[lo:hi]], slot[lo:hi])


def test_edge_cases_one_robot_colocated_and_empty():
    one = _games(np.random.default_rng(0), 1, 1, 10.0)
    ref = windowed_unary(RASTER, SIGNAL, -100.0, *one, softness_db=1.0)
    got = compiled_windowed_unary(RASTER, SIGNAL, -100.0, *one, softness_db=1.0)
    np.testing.assert_allclose(got, ref, rtol=2e-6)
    mask, amask, states, nxt = _games(np.random.default_rng(1), 2, 4, 10.0)
    states[:] = states[:, :1]  # every variable at one point
    nxt = MODEL.apply(states)
    got = compiled_windowed_unary(RASTER, SIGNAL, -100.0, mask, amask, states, nxt)
    ref = windowed_unary(RASTER, SIGNAL, -100.0, mask, amask, states, nxt)
    assert np.isfinite(got).all()
    np.testing.assert_allclose(got, ref, rtol=2e-6, atol=1e-9)
    none = (np.zeros((2, 3), bool), np.zeros((2, 3, 9), bool), states[:, :3], nxt[:, :3])
    assert not compiled_windowed_unary(RASTER, SIGNAL, -100.0, *none).any()


def test_compiled_rejects_a_raster_smaller_than_the_window():
    games = _games(np.random.default_rng(0), 2, 3, 100.0)
    with pytest.raises(ValueError, match="raster pad must be >= the window radius"):
        compiled_windowed_unary(RoiRaster.from_roi(ROI, 2), SIGNAL, -100.0, *games)


def test_potentials_choose_the_kernel_and_reject_an_unknown_one():
    with pytest.raises(ValueError, match="kernel must be one of 'auto', 'compiled', 'numpy'"):
        CoveragePotentials(ROI, SIGNAL, kernel="fast")
    assert CoveragePotentials(ROI, SIGNAL)._compiled
    assert not CoveragePotentials(ROI, SIGNAL, kernel="numpy")._compiled


def _pair_batch(seed, b=6, k=7, spread=60.0):
    mask, amask, states, nxt = _games(np.random.default_rng(seed), b, k, spread)
    return games_of(mask, states, nxt, amask)


@pytest.mark.parametrize(("crowding", "link_term"), [(0.0, "signal"), (0.1, "signal"),
                                                     (0.1, "off"), (0.0, "off")])  # fmt: skip
def test_pair_source_equals_the_weighted_pair_table(crowding, link_term):
    pot = CoveragePotentials(
        ROI, SIGNAL, separation_m=50.0, separation_cost_db=crowding, alpha_b=0.002,
        link_term=link_term,
    )  # fmt: skip
    batch = _pair_batch(7)
    src = pot.pair_source(batch, 0.004, np.float32)
    want = 0.004 * pot.pair_table(batch, np.float32)
    valid = (
        batch.mask[:, :, None, None, None]
        & batch.mask[:, None, None, :, None]
        & ~np.eye(7, dtype=bool)[None, :, None, :, None]
        & batch.action_mask[:, :, :, None, None]
        & batch.action_mask[:, None, None, :, :]
    )
    got = src.table(np.arange(6))
    assert got.dtype == np.float32 and np.all(got[~valid] == 0.0)
    # float32: the logarithm and d² of two computations, a few ulp apart. Alone, the
    # penalty 1 - d / d_sep cancels near d_sep: a few ulp of its scale, not of itself.
    atol = 1e-9 if link_term == "signal" else 1e-6 * float(np.abs(want).max())
    np.testing.assert_allclose(got[valid], want[valid], rtol=1e-6, atol=atol)
    if crowding:  # close pairs pay the penalty: the table is not the signal alone
        plain = CoveragePotentials(ROI, SIGNAL, alpha_b=0.002).pair_source(batch, 0.004, "float32")
        assert (plain.table(np.arange(6)) > got)[valid].any()
    if link_term == "off":  # the crowding penalty alone: 0 beyond its reach, < 0 within
        assert np.all(got <= 0.0) and (got < 0.0).any() == bool(crowding)
    # The table's values at a profile, without the table, bit for bit; sub-batches alike.
    x = np.argmax(batch.action_mask, axis=2)
    at = np.take_along_axis(got, x[:, None, None, :, None], axis=4)[..., 0]
    assert np.array_equal(src.at(x), at)
    assert np.array_equal(src.select([4, 1]).table(np.arange(2)), got[[4, 1]])


@pytest.mark.parametrize("crowding", [0.0, 0.1])
@pytest.mark.parametrize("seed", range(3))
def test_pair_sums_at_a_profile_are_numpys_of_the_rows_bit_for_bit(crowding, seed):
    """``at_sums``: the rows at a profile summed over their outer axis and read at the
    profile, as numpy makes them of ``at``'s (B, K, A, K) rows, padding and invalid actions
    (whose entries may be -0) included, bit for bit."""
    from swarmgames.game.equilibrium import _at_profile

    pot = CoveragePotentials(
        ROI, SIGNAL, separation_m=50.0, separation_cost_db=crowding, alpha_b=0.002
    )
    batch = _pair_batch(seed, b=5, k=9, spread=40.0)
    src = pot.pair_source(batch, 0.004, np.float32)
    rng = np.random.default_rng(seed)
    pick = np.where(batch.action_mask, rng.random(batch.action_mask.shape), -1.0)
    x = np.where(batch.mask, np.argmax(pick, axis=2), 0)
    sums, at_kl = src.at_sums(x)
    rows = src.at(x)
    assert sums.dtype == at_kl.dtype == np.float32
    assert np.array_equal(sums.view(np.int32), rows.sum(axis=3).view(np.int32))
    assert np.array_equal(at_kl.view(np.int32), _at_profile(rows, x).view(np.int32))


def test_pair_source_only_for_float32_with_the_compiled_kernel():
    batch = _pair_batch(0)
    assert CoveragePotentials(ROI, SIGNAL).pair_source(batch, 0.001, np.float64) is None
    numpy = CoveragePotentials(ROI, SIGNAL, kernel="numpy")
    assert numpy.pair_source(batch, 0.001, np.float32) is None
    assert not CoveragePotentials(ROI, SIGNAL, kernel="numpy", link_term="off").pair_on_demand(
        np.float32
    )


_RUN = """
import json, sys
import numpy as np
from swarmgames.config import scaled_config
from swarmgames.bench.stage import StageBench
cfg = scaled_config(60, workers=2).with_overrides({"coverage.kernel": sys.argv[1]})
sb = StageBench(60, cfg, seed=4)
for _ in range(4):
    sb.step()
print(json.dumps(sb.states.tolist()))
"""


def _positions(kernel: str, threads: int) -> np.ndarray:
    env = {**os.environ, "NUMBA_NUM_THREADS": str(threads)}
    out = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(_RUN), kernel],
        env=env,
        capture_output=True,
        text=True,
        check=True,
        timeout=600,
    )
    return np.array(json.loads(out.stdout.strip().splitlines()[-1]))


def test_whole_runs_one_or_two_threads_and_numpy_kernel():
    # Four stages of a 60-UAV constant-density run (float32 tables): bit-identical on 1 and
    # 2 Numba threads (every variable and every game on one thread), and the same flight as
    # the numpy unary and pair table (payoffs equal to float32 rounding: no decision changes
    # in these stages).
    assert scaled_config(60).mission.kernel == "auto"
    one, two = _positions("compiled", 1), _positions("compiled", 2)
    assert np.array_equal(one, two)
    np.testing.assert_array_equal(one, _positions("numpy", 2))
