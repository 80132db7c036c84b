"""Tests of the Figure 2 reproduction (paper section III, Fig. 2)."""

import pandas as pd
import pytest

from swarmgames.config import parse_config
from swarmgames.errors import ConfigError
from swarmgames.experiments.fig2 import reproduce_fig2
from swarmgames.runfolder import RunFolder


@pytest.fixture(scope="module")
def small_fig2():
    base = parse_config({"network": {"backend": "oracle"}, "sim": {"warmup_s": 0.0}})
    return reproduce_fig2((1, 3), base=base, duration_s=4.0, progress=False)


def test_payoff_table_covers_sizes_and_virtual_mean(small_fig2):
    p = small_fig2.payoff
    assert list(p.columns) == ["n_robots", "virtual_mean", "t", "mean_payoff", "coverage"]
    assert sorted(p.groupby(["n_robots", "virtual_mean"]).size().items()) == [
        ((1, "eq3"), 4),
        ((1, "off"), 4),
        ((3, "eq3"), 4),
        ((3, "off"), 4),
    ]
    # every robot's payoff rises as the swarm moves into the ROI (Fig. 2a)
    for _, grp in p.groupby(["n_robots", "virtual_mean"]):
        assert grp["mean_payoff"].iloc[-1] > grp["mean_payoff"].iloc[0]


def test_timing_table(small_fig2):
    t = small_fig2.timing
    assert len(t) == 4
    assert (t[["solve_ms_median", "integrate_ms_median"]] > 0).all().all()
    assert (t["solve_ms_p90"] >= t["solve_ms_median"]).all()


def test_write(small_fig2, tmp_path):
    files = small_fig2.write(RunFolder(tmp_path / "fig2"))
    names = sorted(f.name for f in files)
    assert names == ["config.toml", "fig2.png", "fig2a.csv", "fig2b.csv", "summary.json"]
    again = pd.read_csv(tmp_path / "fig2" / "fig2a.csv")
    assert len(again) == len(small_fig2.payoff)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"sizes": ()}, "sizes must be a non-empty list"),
        ({"sizes": (0, 3)}, "sizes must be a non-empty list"),
        ({"sizes": (3,), "duration_s": 0.0}, r"duration_s must be > 0 \(got 0.0\)"),
    ],
)
def test_bad_arguments(kwargs, match):
    with pytest.raises(ConfigError, match=match):
        reproduce_fig2(progress=False, **kwargs)
