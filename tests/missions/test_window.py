"""The windowed coverage unary against the straightforward full-grid computation."""

import math
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from swarmgames.game import evaluate_payoffs, mean_field
from swarmgames.game.capabilities import PotentialCapabilities
from swarmgames.missions import CoveragePotentials, GaussianROI, HeadingActions, SignalModel
from swarmgames.missions.coverage.window import RoiRaster, floor_distance_sq, windowed_unary
from tests.game.helpers import games_of

T0, L0, N_EXP = 16.0206, 46.6777, 3.0  # ns-3 log-distance defaults, docs/reference.md section 2
ROI = GaussianROI((0.0, 0.0), ((250.0**2, 0.0), (0.0, 200.0**2)), 0.95, 20.0)
SIGNAL = SignalModel(T0, L0, N_EXP, 1.0)
MODEL = HeadingActions(10.0, 8)


def _reference(states, nxt, mask, amask, floor, tau):
    """Eq. 4 over the whole grid with signals clamped at the floor, one variable at a time,
    float64 (the computation the window replaces)."""
    pts, w = ROI.points, ROI.weights

    def psi(p):
        d = np.sqrt(((p[:2] - pts) ** 2).sum(axis=1) + p[2] ** 2)
        return np.maximum(SIGNAL.power(d), floor)

    B, K, A = amask.shape
    out = np.zeros((B, K, A))
    for b in range(B):
        for k in range(K):
            if not mask[b, k]:
                continue
            o = np.full(len(pts), floor)
            for m in range(K):
                if m != k and mask[b, m]:
                    o = np.maximum(o, psi(states[b, m]))
            for x in range(A):
                f = psi(nxt[b, k, x])
                v = np.maximum(f, o) if tau == 0 else tau * np.logaddexp(f / tau, o / tau)
                out[b, k, x] = v @ w
    return out


def _games(rng, b, k, spread):
    states = np.c_[rng.uniform(-spread, spread, (b * k, 2)), np.full(b * k, 30.0)]
    states = states.reshape(b, k, 3)
    mask = np.ones((b, k), dtype=bool)
    mask[:, 1:] = rng.random((b, k - 1)) < 0.8
    nxt = MODEL.apply(states)
    amask = MODEL.valid(states) & mask[..., None]
    return states, nxt, mask, amask


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    floor=st.sampled_from([-110.0, -100.0, -95.0]),
    tau=st.sampled_from([0.0, 1.0]),
    spread=st.sampled_from([150.0, 500.0]),
)
def test_window_differs_from_the_full_grid_by_a_term_free_of_the_action(seed, floor, tau, spread):
    rng = np.random.default_rng(seed)
    states, nxt, mask, amask = _games(rng, 3, 4, spread)
    raster = RoiRaster.from_roi(ROI, 40)
    got = windowed_unary(raster, SIGNAL, floor, mask, amask, states, nxt, softness_db=tau)
    ref = _reference(states, nxt, mask, amask, floor, tau)
    for b, k in zip(*np.nonzero(mask), strict=True):
        diff = (ref[b, k] - got[b, k])[amask[b, k]]
        # float32 signals: the offset is the same for every action to 1e-5 of the unary.
        assert np.ptp(diff) < 1e-5
        # Hence the same best action (up to float32 ties).
        best = np.flatnonzero(amask[b, k])
        assert ref[b, k, best].max() - ref[b, k, best[np.argmax(got[b, k, best])]] < 1e-5
    assert np.all(got[~amask] == 0.0)


def test_same_marginals_as_the_full_grid():
    rng = np.random.default_rng(3)
    states, nxt, mask, amask = _games(rng, 6, 5, 300.0)
    full = _reference(states, nxt, mask, amask, -100.0, 1.0)
    raster = RoiRaster.from_roi(ROI, 40)
    win = windowed_unary(raster, SIGNAL, -100.0, mask, amask, states, nxt, softness_db=1.0)

    class Table:
        capabilities = PotentialCapabilities()

        def __init__(self, u):
            self.u = u

        def unary(self, batch):
            return self.u

        def pairwise(self, batch):
            return None

    batch = SimpleNamespace(
        n_games=6,
        n_vars=5,
        n_actions=9,
        mask=mask,
        action_mask=amask,
        owner=np.arange(6),
        members=np.tile(np.arange(5), (6, 1)),
        valid_pairs=lambda: mask[:, :, None] & mask[:, None, :] & ~np.eye(5, dtype=bool),
        pair_mask=None,
    )
    qa = mean_field(evaluate_payoffs(batch, Table(full), 1.0, 0.0), 50.0).marginals
    qb = mean_field(evaluate_payoffs(batch, Table(win), 1.0, 0.0), 50.0).marginals
    np.testing.assert_allclose(qa, qb, atol=1e-3)
    assert np.array_equal(qa.argmax(axis=2)[mask], qb.argmax(axis=2)[mask])


def test_floor_distance_matches_the_signal_model():
    # psi_R(d_F) = F (paper section III, log-distance model)
    d = math.sqrt(floor_distance_sq(SIGNAL, -100.0))
    assert SIGNAL.power(d) == pytest.approx(-100.0, abs=1e-9)
    # A floor above the signal at d0 gives d0 itself.
    assert floor_distance_sq(SIGNAL, 0.0) == 1.0


def test_isolated_robot_far_outside_the_roi_has_a_flat_unary():
    states = np.array([[[50_000.0, 0.0, 30.0]]])
    mask = np.ones((1, 1), dtype=bool)
    nxt = MODEL.apply(states)
    amask = np.ones((1, 1, 9), dtype=bool)
    raster = RoiRaster.from_roi(ROI, 40)
    got = windowed_unary(raster, SIGNAL, -100.0, mask, amask, states, nxt)
    np.testing.assert_array_equal(got, 0.0)


def test_co_located_robots_are_finite():
    states = np.array([[[0.0, 0.0, 30.0], [0.0, 0.0, 30.0], [0.0, 0.0, 30.0]]])
    mask = np.ones((1, 3), dtype=bool)
    nxt = MODEL.apply(states)
    amask = MODEL.valid(states)
    raster = RoiRaster.from_roi(ROI, 40)
    got = windowed_unary(raster, SIGNAL, -100.0, mask, amask, states, nxt, softness_db=1.0)
    assert np.all(np.isfinite(got))
    ref = _reference(states, nxt, mask, amask, -100.0, 1.0)
    for k in range(3):
        assert np.ptp(ref[0, k] - got[0, k]) < 1e-5


def test_raster_pad_too_small_is_an_error():
    rng = np.random.default_rng(0)
    states, nxt, mask, amask = _games(rng, 1, 2, 100.0)
    with pytest.raises(ValueError, match="raster pad must be >="):
        windowed_unary(RoiRaster.from_roi(ROI, 2), SIGNAL, -100.0, mask, amask, states, nxt)


def test_coverage_potentials_use_the_window_under_a_floor():
    pot = CoveragePotentials(ROI, SIGNAL, softness_db=1.0, signal_floor_dbm=-100.0)
    rng = np.random.default_rng(5)
    states, nxt, mask, amask = _games(rng, 2, 3, 200.0)
    got = pot.unary(games_of(mask, states, nxt, amask))
    ref = _reference(states, nxt, mask, amask, -100.0, 1.0)
    for b, k in zip(*np.nonzero(mask), strict=True):
        assert np.ptp((ref[b, k] - got[b, k])[amask[b, k]]) < 1e-5


def test_raster_holds_the_roi_weights():
    raster = RoiRaster.from_roi(ROI, 3)
    assert raster.weights.sum() == pytest.approx(ROI.weights.sum(), rel=1e-6)
    # Cell centres of the raster fall on the ROI's points.
    iy, ix = np.nonzero(raster.weights)
    xy = raster.origin + np.c_[ix, iy] * raster.cell
    assert np.allclose(np.sort(xy[:, 0]), np.sort(ROI.points[:, 0]))


@pytest.mark.parametrize("workers", [1, 2])
def test_state_ids_and_threads_give_the_same_unary(workers):
    # Shared signals keyed by robot id (real or virtual) equal those of the same games whose
    # variables are numbered by position in the game.
    from swarmgames.config.scaling import scaled_config
    from swarmgames.game import local_games
    from swarmgames.sim.runner import build_mission
    from tests.game.helpers import disk_snapshot, games_of

    cfg = scaled_config(80, workers=workers)
    mission = build_mission(cfg)
    pot, model = mission.potentials, mission.action_model
    pos = np.random.default_rng(1).uniform(-1200, 1200, size=(80, 2))
    pos = np.c_[pos, np.full(80, 30.0)]
    batch = local_games(disk_snapshot(pos[:, :2], 368.84), 2, pos, model)
    assert batch.is_virtual.any()
    by_id = pot.unary(batch)
    plain = games_of(batch.mask, batch.states, batch.next_states, batch.action_mask)
    np.testing.assert_array_equal(by_id, pot.unary(plain))
