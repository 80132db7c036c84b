"""Tests of the Lloyd/Voronoi coverage baseline (Cortes et al. 2004)."""

import numpy as np
import pytest

from swarmgames.missions import GaussianROI, HeadingActions
from swarmgames.missions.coverage.lloyd import lloyd_actions, voronoi_centroids


@pytest.fixture
def roi():
    return GaussianROI((0.0, 0.0), ((200.0**2, 0.0), (0.0, 200.0**2)), 0.95, 10.0)


def test_single_robot_centroid_is_roi_mean(roi):
    # One robot owns the whole ROI: its centroid is the (symmetric) density's mean.
    c = voronoi_centroids(np.array([[300.0, -100.0, 30.0]]), roi)
    np.testing.assert_allclose(c, [[0.0, 0.0]], atol=1e-6)


def test_symmetric_pair_centroids_mirror(roi):
    c = voronoi_centroids(np.array([[-50.0, 0.0, 30.0], [50.0, 0.0, 30.0]]), roi)
    # Each half-plane's centroid of an isotropic Gaussian lies on the x axis, mirrored.
    assert c[0, 0] == pytest.approx(-c[1, 0], abs=1e-6)
    assert c[0, 0] < 0
    np.testing.assert_allclose(c[:, 1], 0.0, atol=1e-6)


def test_robot_without_cell_heads_for_mean(roi):
    # Robot 1 sits behind robot 0, far outside: no ROI cell is closest to it.
    c = voronoi_centroids(np.array([[700.0, 0.0, 30.0], [5000.0, 0.0, 30.0]]), roi)
    np.testing.assert_allclose(c[1], roi.mean)


def test_actions_move_toward_centroid_and_stay_there(roi):
    model = HeadingActions(10.0, 8)
    a = lloyd_actions(np.array([[300.0, 0.0, 30.0]]), roi, model)
    assert a.tolist() == [5]  # heading 180 degrees, toward the mean
    assert lloyd_actions(np.array([[0.0, 0.0, 30.0]]), roi, model).tolist() == [0]


def test_the_coverage_mission_offers_lloyd_as_a_baseline():
    from swarmgames.config import ScenarioConfig
    from swarmgames.missions import get_mission

    entry = get_mission("coverage")
    mission = entry.build(ScenarioConfig())
    assert entry.baselines == ("lloyd",) and list(mission.baselines) == ["lloyd"]
    states = mission.initial_states(7, np.random.default_rng(3))
    expected = lloyd_actions(states, mission.roi, mission.action_model)
    np.testing.assert_array_equal(mission.baselines["lloyd"](states), expected)
