"""Tests of the UAV heading action model."""

import numpy as np
import pytest

from swarmgames.scenarios import HeadingActions, arena_for
from swarmgames.scenarios.roi import GaussianROI


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
