"""The run's figures: units, sane axes for constant series, no warnings for NaN series."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg

from swarmgames.config import resolve_scenario
from swarmgames.labels import column_label
from swarmgames.sim import run
from swarmgames.sim.plots import plot_paths, plot_timeseries


@pytest.fixture(scope="module")
def small():
    config = resolve_scenario(
        "coverage", ["swarm.n_robots=3", "sim.duration_s=3.0", "sim.animation=false"]
    )
    return run(config, out=None, progress=False)


def _drawn(fig) -> None:
    FigureCanvasAgg(fig).draw()


def test_constant_and_nan_series_render_flat_and_without_warnings(small):
    swarm, metrics = small.swarm.copy(), small.metrics.copy()
    swarm["coverage"] = -93.2  # constant
    swarm["mean_info_age_s"] = 0.1 + np.array([0.0, 1e-17, -1e-17])[: len(swarm)]
    swarm["bytes_per_robot"] = np.nan  # nothing measured
    metrics["global_regret"] = np.nan
    metrics["expost_regret"] = np.inf
    result = dataclasses.replace(small, swarm=swarm, metrics=metrics)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fig = plot_timeseries(result)
        _drawn(fig)
        _drawn(plot_paths(result))
    by_label = {ax.get_ylabel(): ax for ax in fig.axes}
    lo, hi = by_label["coverage (dBm)"].get_ylim()
    assert lo == pytest.approx(-93.2 * 1.1) and hi == pytest.approx(-93.2 * 0.9)
    lo, hi = by_label["information age (s)"].get_ylim()
    assert (lo, hi) == pytest.approx((0.09, 0.11))
    assert not by_label["information age (s)"].yaxis.get_offset_text().get_text()


def test_title_names_the_scenario_once_and_legends_stand_above_their_panels(small):
    fig = plot_timeseries(small)
    assert fig.get_suptitle().startswith("coverage: 3 robots")
    for ax in fig.axes:
        legend = ax.get_legend()
        if legend is not None:
            assert legend.get_bbox_to_anchor().y0 >= ax.bbox.y1 - 1e-6


@pytest.mark.parametrize(
    ("name", "label"),
    [
        ("coverage", "coverage (dBm)"),
        ("goal_distance_m", "goal distance (m)"),
        ("mean_speed_m_s", "mean speed (m/s)"),
        ("polarisation", "polarisation"),
        ("median_stage_ms", "median stage (ms)"),
    ],
)
def test_column_labels_carry_units(name, label):
    assert column_label(name) == label
