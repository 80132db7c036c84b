"""``reproduce comms``: variants, aggregation and files (tiny runs)."""

from __future__ import annotations

import numpy as np
import pytest

from swarmgames.config import ScenarioConfig
from swarmgames.errors import ConfigError
from swarmgames.experiments.comms import reproduce_comms
from swarmgames.runfolder import RunFolder


@pytest.fixture(scope="module")
def result():
    base = ScenarioConfig().with_overrides({"sim.duration_s": 6.0, "network.backend": "oracle"})
    return reproduce_comms(
        base=base, seeds=[0, 1], loss_rates=(0.0, 0.6), crashes=(2,), progress=False
    )


def test_every_variant_runs_on_every_seed(result):
    runs = result.runs
    assert len(runs) == 5 * 2
    assert all(sorted(g) == [0, 1] for _, g in runs.groupby("variant")["seed"])
    agg = result.aggregate().set_index("variant")
    assert agg.loc["ideal", "mean_info_age_s_mean"] == 0.0
    assert agg.loc["csma", "mean_info_age_s_mean"] >= 0.1 - 1e-9  # the decision's delay
    lossy = agg.loc["routed, 60% loss"]
    assert lossy["mean_info_age_s_mean"] > agg.loc["routed, 0% loss", "mean_info_age_s_mean"]
    assert lossy["coverage_end_dbm_n"] == 2 and np.isfinite(lossy["coverage_end_dbm_std"])
    assert (runs[runs["variant"] == "routed, 2 crashed"]["crashed"] == 2).all()


def test_files(result, tmp_path):
    files = result.write(RunFolder(tmp_path / "comms"))
    names = {f.name for f in files}
    assert {"runs.csv", "aggregate.csv", "comms.png", "summary.json", "config.toml"} <= names


def test_bad_arguments():
    with pytest.raises(ConfigError, match="seeds must not be empty"):
        reproduce_comms(seeds=[], progress=False)
    with pytest.raises(ConfigError, match=r"crashes must be < swarm\.n_robots"):
        reproduce_comms(seeds=[0], crashes=(7,), progress=False)
