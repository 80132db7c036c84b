"""Tests of the UAV heading action model."""

import numpy as np
import pytest

from swarmgames.missions import HeadingActions, arena_for
from swarmgames.missions.coverage.roi import GaussianROI


def test_actions_move_step_at_constant_altitude():
    m = HeadingActions(10.0, 8)
    s = np.array([[1.0, 2.0, 30.0], [5.0, 5.0, 40.0]])
    nxt = m.apply(s)
    assert nxt.shape == (2, 9, 3)
    np.testing.assert_array_equal(nxt[:, 0], s)  # action 0 = stay
    step = np.linalg.norm(nxt - s[:, None, :], axis=-1)
    np.testing.assert_allclose(step[:, 1:], 10.0)
    np.testing.assert_array_equal(nxt[..., 2], np.repeat(s[:, None, 2], 9, axis=1))
    assert m.labels()[:3] == ["stay", "0deg", "45deg"]


def test_bounds_and_stay_always_valid():
    m = HeadingActions(10.0, 4, (0.0, 100.0, 0.0, 100.0))
    ok = m.valid(np.array([[0.0, 0.0, 30.0], [50.0, 50.0, 30.0], [-50.0, 50.0, 30.0]]))
    # corner: only +x and +y moves stay inside
    assert ok[0].tolist() == [True, True, True, False, False]
    assert ok[1].all()
    # outside: moves that do not increase the distance to the arena
    assert ok[2].tolist() == [True, True, True, False, True]


def test_arena_holds_roi_and_takeoff():
    roi = GaussianROI((0, 0), ((1e4, 0), (0, 1e4)), 0.95, 10.0)
    xmin, xmax, ymin, _ = arena_for(roi, (-1000.0, 0.0), 10.0, 5.0)
    assert ymin == pytest.approx(roi.bounding_box()[2] - 5.0)
    assert xmin == pytest.approx(-1015.0)
    assert xmax == pytest.approx(roi.bounding_box()[1] + 5.0)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"step_m": 0.0}, r"step_m must be > 0 \(got 0.0\)"),
        ({"step_m": 1.0, "n_headings": 0}, "n_headings must be an integer >= 1"),
        ({"step_m": 1.0, "bounds": (1.0, 0.0, 0.0, 1.0)}, "xmin < xmax"),
    ],
)
def test_bad_parameters(kwargs, match):
    with pytest.raises(ValueError, match=match):
        HeadingActions(**kwargs)


def test_acceleration_labels_of_the_authors_controller():
    # docs/reference.md section 5: 25 labels on a +-0.5 m/s^2 grid, step 0.25, over 1 s, |v| <= 1.
    from swarmgames.missions import AccelerationActions

    m = AccelerationActions(0.25, 2, 1.0, 1.0)
    assert m.n_actions == 25
    assert m.accels[0].tolist() == [0.0, 0.0]  # action 0 = no acceleration
    assert sorted(set(m.accels[:, 0].tolist())) == [-0.5, -0.25, 0.0, 0.25, 0.5]
    s = np.array([[0.0, 0.0, 30.0, 0.0, 0.0], [5.0, 5.0, 30.0, 0.9, 0.0]])
    nxt = m.apply(s)
    assert nxt.shape == (2, 25, 5)
    # from rest: p' = a dt^2 / 2, v' = a dt
    np.testing.assert_allclose(nxt[0, :, 3:5], m.accels)
    np.testing.assert_allclose(nxt[0, :, 0:2], 0.5 * m.accels)
    assert np.linalg.norm(nxt[1, :, 3:5], axis=1).max() <= 1.0 + 1e-12  # speed cap
    np.testing.assert_array_equal(nxt[..., 2], 30.0)


def test_acceleration_near_the_arena_edge_keeps_one_action():
    from swarmgames.missions import AccelerationActions

    m = AccelerationActions(0.25, 2, 1.0, 1.0, (-100.0, 100.0, -100.0, 100.0))
    ok = m.valid(np.array([99.9, 0.0, 30.0, 1.0, 0.0]))
    assert ok.sum() >= 1
    best = np.argmax(ok)
    assert m.accels[best, 0] == -0.5  # the hardest braking is the one left
    with pytest.raises(ValueError, match="states must have 5 columns"):
        m.apply(np.zeros(3))
    with pytest.raises(ValueError, match=r"accel_step must be > 0 \(got 0.0\)"):
        AccelerationActions(0.0)
