"""Tests of the virtual-mean study at scale (``reproduce fig2-scale``): the scenario at
constant density for every N, the study's tables on tiny runs, resuming, and its errors."""

from __future__ import annotations

import json
import math

import pandas as pd
import pytest
from click.testing import CliRunner

from swarmgames.cli import cli
from swarmgames.config import parse_config, resolve_scenario
from swarmgames.config.io import to_data
from swarmgames.errors import ConfigError, RunFolderError
from swarmgames.experiments import fig2_scale
from swarmgames.experiments.fig2_scale import reproduce_fig2_scale, scenario_for
from swarmgames.experiments.sweep import executors


def _area_per_robot(cfg) -> float:
    """ROI area (the disc at the mission's confidence) per UAV, m²."""
    k2 = -2.0 * math.log1p(-cfg.mission.confidence)
    return math.pi * k2 * cfg.mission.roi_cov_m2[0][0] / cfg.swarm.n_robots


def test_the_scenario_keeps_its_density_and_take_off_disc_for_every_size():
    base = resolve_scenario("fig2-scale")
    assert _area_per_robot(base) == pytest.approx(70_000.0)
    for n in (10, 100, 1000):
        cfg = scenario_for(n, base)
        assert cfg.swarm.n_robots == n
        assert _area_per_robot(cfg) == pytest.approx(70_000.0)
        assert cfg.swarm.start_center_m == base.swarm.start_center_m
        assert cfg.swarm.start_radius_m == base.swarm.start_radius_m
        game = cfg.game
        assert (game.alpha_b, game.pair_weighting, cfg.mission.move_cost_db) == (1e-3, "mean", 0)
        assert cfg.mission.signal_floor_dbm == base.mission.signal_floor_dbm
    # the 100-UAV instance is the scenario file itself
    cov = scenario_for(100, base).mission.roi_cov_m2
    assert [*cov[0], *cov[1]] == pytest.approx([*base.mission.roi_cov_m2[0], 0.0, cov[1][1]])
    assert cov[1][1] == pytest.approx(base.mission.roi_cov_m2[1][1])


#: Five and six UAVs, three stages: the study's mechanics on runs of a second.
TINY = {"sim": {"duration_s": 3.0, "warmup_s": 1.0}}


@pytest.fixture(scope="module")
def tiny_base():
    data = to_data(resolve_scenario("fig2-scale"))
    for section, fields in TINY.items():
        data[section].update(fields)
    return parse_config(data)


@pytest.fixture(scope="module")
def study(tiny_base, tmp_path_factory):
    out = tmp_path_factory.mktemp("fig2s") / "study"
    res = reproduce_fig2_scale(
        out, sizes=(5, 6), seeds=(0, 1), variants=(True, False), base=tiny_base, jobs=1
    )
    return out, res


def test_the_study_writes_the_tables_of_every_size_variant_and_seed(study):
    out, res = study
    names = sorted(p.name for p in out.iterdir())
    assert {"results.csv", "aggregate.csv", "paired.csv", "study.json", "n5", "n6"} <= set(names)
    assert {"coverage_end_dbm.png", "coverage_gain_db.png"} <= set(names)
    r = res.results
    assert list(r.columns[:4]) == ["swarm.n_robots", "game.virtual_mean", "seed", "status"]
    assert (r["status"] == "complete").all()
    assert sorted(zip(r["swarm.n_robots"], r["game.virtual_mean"], r["seed"], strict=True)) == [
        (n, vm, s) for n in (5, 6) for vm in (False, True) for s in (0, 1)
    ]
    assert (r["n_robots"] == r["swarm.n_robots"]).all()
    gain = r["coverage_end_dbm"] - r["coverage_start_dbm"]
    assert r["coverage_gain_db"].tolist() == gain.tolist()
    for folder in r["folder"]:
        assert (out / folder / "summary.json").exists()
    again = pd.read_csv(out / "results.csv")
    assert len(again) == len(r)


def test_aggregate_is_per_size_and_variant_and_paired_compares_variants_on_the_same_seeds(study):
    _, res = study
    agg = res.aggregate()
    cov = agg[agg["metric"] == "coverage_end_dbm"]
    assert len(cov) == 4 and (cov["n"] == 2).all()
    paired = res.paired()
    assert set(paired["factor"]) == {"game.virtual_mean"}
    row = paired[(paired["metric"] == "coverage_end_dbm") & (paired["swarm.n_robots"] == 5)]
    r = res.results.set_index(["swarm.n_robots", "game.virtual_mean", "seed"])["coverage_end_dbm"]
    expected = [r[(5, False, s)] - r[(5, True, s)] for s in (0, 1)]
    assert row["mean"].item() == pytest.approx(sum(expected) / 2)


def test_the_same_study_again_runs_nothing_and_may_add_seeds(study, tiny_base, monkeypatch):
    out, res = study
    ran = []
    real = executors.execute
    monkeypatch.setattr(executors, "execute", lambda task: ran.append(task) or real(task))
    again = reproduce_fig2_scale(
        out, sizes=(5, 6), seeds=(0, 1), variants=(True, False), base=tiny_base, jobs=1
    )
    assert ran == []
    cols = ["swarm.n_robots", "game.virtual_mean", "seed", "coverage_end_dbm"]
    pd.testing.assert_frame_equal(again.results[cols], res.results[cols])
    more = reproduce_fig2_scale(
        out, sizes=(5,), seeds=(0, 1, 2), variants=(True,), base=tiny_base, jobs=1
    )
    assert len(ran) == 1 and len(more.results) == 3
    assert json.loads((out / "study.json").read_text())["seeds"] == [0, 1, 2]


def test_a_folder_of_another_study_or_of_something_else_is_refused(study, tmp_path):
    out, _ = study
    other = parse_config({**to_data(resolve_scenario("fig2-scale")), "name": "other"})
    with pytest.raises(RunFolderError, match="study of another scenario"):
        reproduce_fig2_scale(out, sizes=(5,), seeds=(0,), variants=(True,), base=other)
    (tmp_path / "x.txt").write_text("mine")
    with pytest.raises(RunFolderError, match="holds no fig2-scale study"):
        reproduce_fig2_scale(tmp_path, sizes=(5,), seeds=(0,), variants=(True,))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.txt"]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"sizes": ()}, "sizes: must be a non-empty list"),
        ({"sizes": (5, 5)}, "sizes: must be a non-empty list without repeats"),
        ({"sizes": (0,)}, r"sizes: must be integers >= 1 \(got \(0,\)\)"),
        ({"variants": ()}, "variants: must be a non-empty list"),
        ({"variants": ("sometimes",)}, "game.virtual_mean"),
    ],
)
def test_bad_arguments_are_refused_before_anything_is_written(kwargs, match, tmp_path):
    with pytest.raises(ConfigError, match=match):
        reproduce_fig2_scale(tmp_path / "s", **{"sizes": (5,), "seeds": (0,), **kwargs})
    assert not (tmp_path / "s").exists()


def test_the_command_line(tiny_base, tmp_path):
    runner = CliRunner()
    out = tmp_path / "cli"
    args = ["reproduce", "fig2-scale", "--sizes", "5", "--seeds", "0", "--variants", "true"]
    sets = ["--set", "sim.duration_s=3.0", "--set", "sim.warmup_s=1.0", "--jobs", "1"]
    res = runner.invoke(cli, [*args, *sets, "--out", str(out), "--no-progress"])
    assert res.exit_code == 0, res.output
    assert "1 runs: 1 complete" in res.output
    assert (out / "results.csv").exists()
    bad = runner.invoke(cli, [*args[:2], "--sizes", "5,x", "--out", str(tmp_path / "b")])
    assert bad.exit_code == 2 and "--sizes" in bad.output
    bad = runner.invoke(
        cli, [*args[:2], "--sizes", "5", "--variants", "maybe", "--out", str(tmp_path / "b")]
    )
    assert bad.exit_code == 2 and "game.virtual_mean" in bad.output
    assert fig2_scale.VARIANTS[0] == "eq3"
