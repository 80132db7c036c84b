"""Tests of the coverage potentials (paper eqs. 5 and 6) and the coverage metric."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from swarmgames.game.inertia import Inertia
from swarmgames.missions import CoveragePotentials, GaussianROI, HeadingActions, SignalModel
from tests.game.helpers import games_of

T0, L0, N_EXP = 16.0206, 46.6777, 3.0  # ns-3 log-distance defaults, docs/reference.md section 2


def _psi(d):
    # paper section III: psi_R = T0 - (L0 + 10 n log10 d), clamped at d0 = 1 m
    return T0 - (L0 + 10.0 * N_EXP * math.log10(max(d, 1.0)))


def _batch(states, members_mask, model):
    states = np.asarray(states, dtype=float)
    mask = np.asarray(members_mask, dtype=bool)
    return games_of(mask, states, model.apply(states), model.valid(states) & mask[..., None])


@pytest.fixture
def small():
    # A coarse grid (cell 60 m) keeps the hand computation short.
    roi = GaussianROI((0.0, 0.0), ((150.0**2, 0.0), (0.0, 100.0**2)), 0.9, 60.0)
    return CoveragePotentials(roi, SignalModel(T0, L0, N_EXP, 1.0)), HeadingActions(20.0, 4)


def test_two_robots_against_hand_computation(small):
    pot, model = small
    s0, s1 = (-40.0, 10.0, 30.0), (80.0, -20.0, 30.0)
    batch = _batch([[s0, s1]], [[True, True]], model)
    u = pot.unary(batch)
    p = pot.pairwise(batch)
    pts, w = pot.roi.points, pot.roi.weights

    def d3(a, r):
        return math.sqrt((a[0] - r[0]) ** 2 + (a[1] - r[1]) ** 2 + a[2] ** 2)

    for k, (me, other) in enumerate([(s0, s1), (s1, s0)]):
        for a in range(model.n_actions):
            nx = (me[0] + model.offsets[a, 0], me[1] + model.offsets[a, 1], me[2])
            # eq. 5: sum over cells of p(r) a^2 * max(psi(own next state), psi(other's state))
            hand = sum(
                wg * max(_psi(d3(nx, r)), _psi(d3(other, r))) for r, wg in zip(pts, w, strict=True)
            )
            assert u[0, k, a] == pytest.approx(hand, abs=1e-3)
    for a in range(model.n_actions):
        for b in range(model.n_actions):
            n0 = np.add(s0, model.offsets[a])
            n1 = np.add(s1, model.offsets[b])
            # eq. 6: link quality between the two next states, both at 30 m
            hand = _psi(math.dist(n0, n1))
            assert p[0, 0, 1, a, b] == pytest.approx(hand, abs=1e-4)
            assert p[0, 1, 0, b, a] == pytest.approx(hand, abs=1e-4)
    assert np.all(p[0, 0, 0] == 0) and np.all(p[0, 1, 1] == 0)

    # Payoff of the local game (eq. 1) for one profile, alpha_a = 1, alpha_b = 0.001.
    x0, x1 = 1, 3
    m = u[0, 0, x0] + u[0, 1, x1] + 0.001 * (p[0, 0, 1, x0, x1] + p[0, 1, 0, x1, x0])
    n0, n1 = np.add(s0, model.offsets[x0]), np.add(s1, model.offsets[x1])
    hand = (
        sum(wg * max(_psi(d3(n0, r)), _psi(d3(s1, r))) for r, wg in zip(pts, w, strict=True))
        + sum(wg * max(_psi(d3(n1, r)), _psi(d3(s0, r))) for r, wg in zip(pts, w, strict=True))
        + 0.002 * _psi(math.dist(n0, n1))
    )
    assert m == pytest.approx(hand, abs=2e-3)


def test_one_robot_unary_is_own_integral(small):
    pot, model = small
    batch = _batch([[[10.0, 0.0, 30.0]]], [[True]], model)
    u = pot.unary(batch)
    f = pot.signal.field(model.apply(np.array([10.0, 0.0, 30.0])), pot.roi.points, np.float64)
    np.testing.assert_allclose(u[0, 0], f @ pot.roi.weights, atol=1e-3)
    assert pot.pairwise(batch).shape == (1, 1, 1, 5, 5)
    assert np.all(pot.pairwise(batch) == 0)


def test_colocated_robots_are_finite(small):
    pot, model = small
    batch = _batch([[[0.0, 0.0, 0.0]] * 3], [[True] * 3], model)
    assert np.all(np.isfinite(pot.unary(batch)))
    p = pot.pairwise(batch)
    assert np.all(np.isfinite(p))
    assert p[0, 0, 1, 0, 0] == pytest.approx(T0 - L0)  # d = 0 clamped to d0 = 1 m


def _reference_unary(pot, batch):
    """Direct float64 evaluation of eq. 5, one variable and action at a time."""
    B, K, A = batch.action_mask.shape
    out = np.zeros((B, K, A))
    pts, w = pot.roi.points, pot.roi.weights
    for b in range(B):
        for k in range(K):
            if not batch.mask[b, k]:
                continue
            others = [j for j in range(K) if j != k and batch.mask[b, j]]
            o = (
                pot.signal.field(batch.states[b, others], pts, np.float64).max(axis=0)
                if others
                else np.full(len(pts), -np.inf)
            )
            f = pot.signal.field(batch.next_states[b, k], pts, np.float64)
            out[b, k] = np.maximum(f, o) @ w
            out[b, k, ~batch.action_mask[b, k]] = 0.0
    return out


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    b=st.integers(1, 5),
    k=st.integers(1, 5),
    chunk=st.sampled_from([1, 500, 4_000_000]),
)
def test_vectorised_unary_matches_reference(seed, b, k, chunk):
    rng = np.random.default_rng(seed)
    roi = GaussianROI((0.0, 0.0), ((200.0**2, 0.0), (0.0, 200.0**2)), 0.95, 50.0)
    pot = CoveragePotentials(roi, chunk_elems=chunk)
    model = HeadingActions(15.0, 8, (-400.0, 400.0, -400.0, 400.0))
    xy = rng.uniform(-450, 450, (b, k, 2))
    xy[:, 1:2] = xy[:, 0:1] if k > 1 and rng.random() < 0.3 else xy[:, 1:2]  # co-located
    states = np.concatenate([xy, np.full((b, k, 1), 30.0)], axis=-1)
    mask = rng.random((b, k)) < 0.8
    mask[:, 0] = True
    batch = _batch(states, mask, model)
    np.testing.assert_allclose(pot.unary(batch), _reference_unary(pot, batch), atol=2e-3)
    assert pot.last_integrate_s > 0


def test_coverage_metric(small):
    pot, _ = small
    centre = pot.coverage(np.array([[0.0, 0.0, 30.0]]))
    far = pot.coverage(np.array([[2000.0, 0.0, 30.0]]))
    both = pot.coverage(np.array([[0.0, 0.0, 30.0], [2000.0, 0.0, 30.0]]))
    assert centre > far
    assert both == pytest.approx(centre, abs=1e-5)  # the best signal ignores the far robot
    f = pot.signal.field(np.array([[0.0, 0.0, 30.0]]), pot.roi.points, np.float64)[0]
    assert centre == pytest.approx(f @ pot.roi.weights / pot.roi.weights.sum(), abs=1e-4)
    with pytest.raises(ValueError, match="at least one robot"):
        pot.coverage(np.zeros((0, 3)))


def test_move_cost_and_crowding_penalty(small):
    base, model = small
    roi, sig = base.roi, base.signal
    pot = Inertia(
        CoveragePotentials(
            roi, sig, separation_m=50.0, separation_cost_db=0.1, separation_mode="unary"
        ),
        0.01 * roi.mass,
    )
    s = np.array([[[0.0, 0.0, 30.0], [20.0, 0.0, 30.0]]])
    batch = _batch(s, [[True, True]], model)
    diff = base.unary(batch) - pot.unary(batch)
    nxt = model.apply(s[0])  # (2, A, 3)
    for k, other in ((0, 1), (1, 0)):
        d = np.linalg.norm(nxt[k] - s[0, other], axis=-1)
        crowd = 0.1 * roi.mass * np.maximum(0.0, 1.0 - d / 50.0) ** 2
        moved = np.r_[0.0, np.full(model.n_actions - 1, 0.01 * roi.mass)]
        np.testing.assert_allclose(diff[0, k], crowd + moved, atol=1e-9)
    # moving away from the neighbour (heading 180 degrees for robot 0) is penalised least
    assert np.argmin(diff[0, 0, 1:]) + 1 == 3  # 4 headings: 0, 90, 180, 270 degrees


def test_smooth_maximum(small):
    base, model = small
    pot = CoveragePotentials(base.roi, base.signal, softness_db=2.0)
    s = np.array([[[0.0, 0.0, 30.0], [60.0, 30.0, 30.0]]])
    batch = _batch(s, [[True, True]], model)
    u = pot.unary(batch)
    pts, w = base.roi.points, base.roi.weights
    for k, other in ((0, 1), (1, 0)):
        f = base.signal.field(model.apply(s[0, k]), pts, np.float64)  # (A, G)
        o = base.signal.field(s[0, other][None], pts, np.float64)[0]
        smooth = 2.0 * np.logaddexp(f / 2.0, o / 2.0)  # tau ln(e^(a/tau) + e^(b/tau))
        np.testing.assert_allclose(u[0, k], smooth @ w, atol=2e-3)
    # never below the hard maximum, at most tau ln 2 above it
    excess = u - base.unary(batch)
    assert np.all(excess >= -1e-4) and np.all(excess <= 2.0 * np.log(2) * base.roi.mass + 1e-4)
    # one robot: nothing to smooth against
    one = _batch(s[:, :1], [[True]], model)
    np.testing.assert_allclose(pot.unary(one), base.unary(one), atol=1e-6)


def _crowding_dense(pot, mask, states, nxt):
    # Straightforward sum over every other variable (the computation the sparse sum replaces).
    B, K, A = nxt.shape[:3]
    out = np.zeros((B, K, A))
    for b in range(B):
        for k in range(K):
            for m in range(K):
                if m == k or not (mask[b, k] and mask[b, m]):
                    continue
                d = np.linalg.norm(nxt[b, k] - states[b, m], axis=-1)
                out[b, k] += np.maximum(0.0, 1.0 - d / pot.separation_m) ** 2
    return pot.separation_cost_db * pot.roi.mass * out


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), spread=st.sampled_from([20.0, 60.0, 300.0]))
def test_sparse_crowding_equals_the_dense_sum(seed, spread):
    roi = GaussianROI((0.0, 0.0), ((150.0**2, 0.0), (0.0, 100.0**2)), 0.9, 60.0)
    model = HeadingActions(20.0, 4)
    pot = CoveragePotentials(
        roi, SignalModel(), separation_m=50.0, separation_cost_db=0.1, separation_mode="unary"
    )
    rng = np.random.default_rng(seed)
    states = np.c_[rng.uniform(-spread, spread, (12, 2)), np.full(12, 30.0)].reshape(3, 4, 3)
    mask = rng.random((3, 4)) < 0.8
    nxt = model.apply(states)
    np.testing.assert_allclose(
        pot._crowding(mask, states, nxt), _crowding_dense(pot, mask, states, nxt), rtol=1e-12
    )


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_pair_table_equals_the_dense_pairwise_table(small, dtype):
    pot, model = small
    rng = np.random.default_rng(2)
    states = np.c_[rng.uniform(-300, 300, (8, 2)), np.full(8, 30.0)].reshape(2, 4, 3)
    batch = _batch(states, [[1, 1, 1, 0], [1, 1, 1, 1]], model)
    dense = pot.pairwise(batch)  # (B, K, K, A, A)
    sym = dense.transpose(0, 1, 3, 2, 4) + dense.transpose(0, 2, 4, 1, 3)
    table = pot.pair_table(batch, dtype)
    assert table.dtype == dtype and table.shape == sym.shape
    valid = (
        batch.mask[:, :, None, None, None]
        & batch.mask[:, None, None, :, None]
        & ~np.eye(4, dtype=bool)[None, :, None, :, None]
        & batch.action_mask[:, :, :, None, None]
        & batch.action_mask[:, None, None, :, :]
    )
    tol = 0.0 if dtype == np.float64 else 1e-5
    np.testing.assert_allclose(table[valid], sym[valid], rtol=tol, atol=tol)


def test_best_signal_by_nearest_uav_equals_the_dense_field(small, monkeypatch):
    import swarmgames.missions.coverage.potentials as cov

    pot, _ = small
    rng = np.random.default_rng(4)
    pos = np.c_[rng.uniform(-300, 300, (9, 2)), rng.uniform(0, 60, 9)]
    dense = pot.best_signal(pos)
    monkeypatch.setattr(cov, "_DENSE_METRIC_ELEMS", 0)
    np.testing.assert_allclose(pot.best_signal(pos), dense, atol=1e-4)


def _two_robot_game(model, gap_m=1.0):
    from swarmgames.game import local_games
    from swarmgames.network import TopologySnapshot

    states = np.array([[-100.0, 0.0, 30.0], [-100.0, gap_m, 30.0]])
    snap = TopologySnapshot.from_hop_matrix(0.0, [[0, 1], [1, 0]])
    return states, local_games(snap, 2, states, model)


def _crowding_in_payoff(base, batch, mode, profile):
    """The crowding part of M_i (eq. 1) at a joint profile of both robots."""
    from swarmgames.game import evaluate_payoffs, profile_payoff

    pot = CoveragePotentials(
        base.roi, base.signal, separation_m=50.0, separation_cost_db=0.1, separation_mode=mode
    )
    prof = np.tile(profile, (batch.n_games, 1))
    with_c = profile_payoff(evaluate_payoffs(batch, pot, 1.0, 0.001), prof)
    without = profile_payoff(evaluate_payoffs(batch, base, 1.0, 0.001), prof)
    return with_c - without


@pytest.mark.parametrize("heading", [1, 2, 3, 4])
def test_pairwise_crowding_charges_a_joint_move_at_the_next_positions(small, heading):
    # Two robots 1 m apart moving together stay 1 m apart: the pairwise penalty (both
    # robots' next positions) charges the joint move exactly as staying, -c_sep * mass *
    # sum over ordered pairs of (1 - d / d_sep)^2 (eq. 1 sums k != l over ordered pairs).
    base, model = small
    _, batch = _two_robot_game(model)
    together = _crowding_in_payoff(base, batch, "pairwise", [heading, heading])
    stay = _crowding_in_payoff(base, batch, "pairwise", [0, 0])
    expected = -2 * 0.1 * base.roi.mass * (1.0 - 1.0 / 50.0) ** 2
    np.testing.assert_allclose(stay, expected, rtol=1e-9)
    np.testing.assert_allclose(together, expected, rtol=1e-9)
    # Moving apart does lower it.
    apart = _crowding_in_payoff(base, batch, "pairwise", [heading, 0])
    assert np.all(apart > stay + 0.01 * base.roi.mass)


@pytest.mark.parametrize("heading", [1, 2, 3, 4])
def test_unary_crowding_believes_a_joint_move_escapes(small, heading):
    # The mechanism of the lockstep oscillation: scored against the other's current
    # position, each robot of a co-located pair believes that any move escapes the crowding,
    # also when both make the same move and stay 1 m apart.
    base, model = small
    _, batch = _two_robot_game(model)
    together = _crowding_in_payoff(base, batch, "unary", [heading, heading])
    stay = _crowding_in_payoff(base, batch, "unary", [0, 0])
    assert np.all(together > stay + 0.01 * base.roi.mass)


def test_pairwise_crowding_table_matches_pairwise(small):
    base, model = small
    pot = CoveragePotentials(
        base.roi, base.signal, separation_m=50.0, separation_cost_db=0.1, separation_mode="pairwise"
    )
    s = np.array([[[0.0, 0.0, 30.0], [20.0, 0.0, 30.0], [35.0, 12.0, 30.0]]])
    batch = _batch(s, [[True, True, True]], model)
    p = pot.pairwise(batch)  # (B, K, K, A, A)
    sym = p.transpose(0, 1, 3, 2, 4) + p.transpose(0, 2, 4, 1, 3)
    table = pot.pair_table(batch, np.float64)
    off = ~np.eye(3, dtype=bool)[None, :, None, :, None]
    np.testing.assert_allclose(np.where(off, table, 0), np.where(off, sym, 0), rtol=1e-12)
    table32 = pot.pair_table(batch, np.float32)
    np.testing.assert_allclose(np.where(off, table32, 0), np.where(off, sym, 0), rtol=1e-5)
    # The crowding part is divided by the pairwise weight, so alpha_b * table carries it at
    # separation_cost_db: robots 0 and 1 staying 20 m apart.
    crowd = (
        table[0, 0, 0, 1, 0] - pot.__class__(base.roi, base.signal).pair_table(batch)[0, 0, 0, 1, 0]
    )
    expected = -2 * 0.1 * base.roi.mass * (1 - 20.0 / 50.0) ** 2
    assert 0.001 * crowd == pytest.approx(expected, rel=1e-9)
    # and no crowding in the unary
    np.testing.assert_allclose(pot.unary(batch), base.unary(batch), atol=1e-9)


def test_pairwise_crowding_rejects_a_zero_pair_weight(small):
    base, _ = small
    with pytest.raises(ValueError, match="pairwise weight > 0"):
        CoveragePotentials(
            base.roi,
            base.signal,
            separation_m=50.0,
            separation_cost_db=0.1,
            alpha_b=0.0,
            separation_mode="pairwise",
        )
    with pytest.raises(ValueError, match="separation_mode must be"):
        CoveragePotentials(base.roi, base.signal, separation_mode="both")
    # no crowding: a zero pair weight is fine (the paper with alpha_b = 0)
    CoveragePotentials(base.roi, base.signal, alpha_b=0.0, separation_mode="pairwise")


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_dense_games_in_small_chunks_are_bit_identical(small, dtype):
    # Regression (dense neighbourhoods): a game larger than the chunk is integrated in slices
    # of variables and its pair table built in blocks of rows; 25 co-clustered robots (every
    # pair within the crowding distance) in 3 games.
    base, model = small
    rng = np.random.default_rng(4)
    states = np.c_[rng.uniform(-30, 30, (3, 25, 2)), np.full((3, 25, 1), 30.0)]
    mask = np.ones((3, 25), dtype=bool)
    mask[2, 20:] = False
    batch = _batch(states, mask, model)
    kwargs = {"softness_db": 1.0, "separation_m": 50.0, "separation_cost_db": 0.1}
    one = CoveragePotentials(base.roi, base.signal, chunk_elems=10**12, **kwargs)
    sliced = CoveragePotentials(base.roi, base.signal, chunk_elems=2_000, **kwargs)
    np.testing.assert_array_equal(sliced.unary(batch), one.unary(batch))
    np.testing.assert_array_equal(sliced.pairwise(batch), one.pairwise(batch))
    if dtype == np.float64:
        np.testing.assert_array_equal(sliced.pair_table(batch, dtype), one.pair_table(batch, dtype))


def test_crowding_blocks_in_chunks_equal_one_block(small):
    from swarmgames.missions.geometry import crowding_blocks

    _, model = small
    rng = np.random.default_rng(5)
    states = np.c_[rng.uniform(-40, 40, (2, 12, 2)), np.full((2, 12, 1), 30.0)]
    batch = _batch(states, np.ones((2, 12), dtype=bool), model)
    whole = list(crowding_blocks(batch, 50.0, max_elems=10**9))
    parts = list(crowding_blocks(batch, 50.0, max_elems=3 * 25))  # 3 pairs of 5 x 5 actions
    assert len(whole) == 1 and len(parts) > 10
    for i in range(4):
        np.testing.assert_array_equal(np.concatenate([p[i] for p in parts]), whole[0][i])
    # The values are np.linalg.norm's, bit for bit.
    gb, gk, gl, pen = whole[0]
    nxt = np.asarray(batch.next_states)
    d = np.linalg.norm(nxt[gb, gk][:, :, None, :] - nxt[gb, gl][:, None, :, :], axis=-1)
    np.testing.assert_array_equal(pen, np.maximum(0.0, 1.0 - d / 50.0) ** 2)
