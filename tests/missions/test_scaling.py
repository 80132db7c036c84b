"""Constant-density scenarios."""

import math

import pytest

from swarmgames.config import ScenarioConfig
from swarmgames.config.scaling import scaled_config
from swarmgames.missions import GaussianROI


def _roi(cov) -> GaussianROI:
    return GaussianROI(cov.roi_mean_m, cov.roi_cov_m2, cov.confidence, cov.grid_cell_m)


@pytest.mark.parametrize("n", [1, 10, 1000])
def test_roi_area_grows_with_n(n):
    cfg = scaled_config(n, area_per_robot_m2=50_000.0)
    var = cfg.mission.roi_cov_m2[0][0]
    k2 = -2.0 * math.log1p(-cfg.mission.confidence)
    # Area of the 95 % ellipse of N(0, var I) is pi k2 var (chi-square with 2 degrees of freedom).
    assert math.pi * k2 * var == pytest.approx(n * 50_000.0)
    assert cfg.swarm.n_robots == n
    assert math.pi * cfg.swarm.start_radius_m**2 == pytest.approx(n * 50_000.0)
    assert cfg.mission.grid_cell_m == ScenarioConfig().mission.grid_cell_m


def test_cells_per_robot_are_constant():
    cells = [_roi(scaled_config(n).mission).n_cells / n for n in (100, 1000)]
    # 70 000 m2 per robot on 20 m cells: 175 cells each (up to the ellipse's edge cells).
    assert cells == pytest.approx([175.0, 175.0], rel=0.02)


def test_settings_of_the_base_are_kept():
    base = ScenarioConfig(seed=4, swarm={"step_m": 5.0})
    cfg = scaled_config(50, base=base, backend="oracle", signal_floor_dbm=None)
    assert cfg.seed == 4 and cfg.swarm.step_m == 5.0
    assert cfg.network.backend == "oracle" and cfg.mission.signal_floor_dbm is None


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"n_robots": 0}, "n_robots must be an integer >= 1"),
        ({"n_robots": 10, "area_per_robot_m2": 0.0}, "area_per_robot_m2 must be > 0"),
    ],
)
def test_invalid_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        scaled_config(**kwargs)
