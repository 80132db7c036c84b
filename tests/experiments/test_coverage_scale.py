"""Tests of the coverage study at scale (``reproduce coverage-scale``): the variants'
configurations, the links measured from a run folder, the study's tables on tiny runs,
resuming, and its errors."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from swarmgames.cli import cli
from swarmgames.config import parse_config, resolve_scenario
from swarmgames.config.io import apply_overrides, to_data
from swarmgames.errors import ConfigError, RunFolderError
from swarmgames.experiments import coverage_scale
from swarmgames.experiments.coverage_scale import (
    MEASURES,
    VARIANT_OVERRIDES,
    reproduce_coverage_scale,
    run_connectivity,
    run_measures,
)
from swarmgames.experiments.sweep import executors
from swarmgames.missions.geometry import relative_neighbours
from swarmgames.network.links import link_graph
from swarmgames.network.propagation import PropagationModel

#: Three stages after a one-second warm-up: the study's mechanics on runs of a second.
TINY = ("sim.duration_s=3.0", "sim.warmup_s=1.0")


def test_the_variants_are_valid_configurations_that_differ_where_they_say():
    base = resolve_scenario("coverage-large")
    nolink = apply_overrides(base, dict(VARIANT_OVERRIDES["game-nolink"]))
    assert nolink.mission.link_term == "off"
    assert nolink.mission.separation_mode == "pairwise"  # only the link term changes
    assert nolink.mission.separation_cost_db == base.mission.separation_cost_db
    lloyd = apply_overrides(base, dict(VARIANT_OVERRIDES["lloyd"]))
    assert lloyd.sim.controller == "lloyd" and lloyd.game.alpha_b == base.game.alpha_b
    # A pairwise weight of 0 is refused: the preset's crowding penalty rides on the
    # pairwise term, whose weight the preset derives from its share.
    with pytest.raises(ConfigError, match=r"game\.alpha_b must be > 0"):
        apply_overrides(base, {"coverage.alpha_b_share": 0.0})


def _fake_run(folder, first, last):
    """A run folder with a trajectory of two recorded positions per robot and a summary."""
    folder.mkdir()
    rows = [
        (t, k, *xy, 30.0, 0) for t, pos in ((10.0, first), (11.0, last)) for k, xy in enumerate(pos)
    ]
    pd.DataFrame(rows, columns=["t", "robot", "x", "y", "z", "action"]).to_csv(
        folder / "trajectory.csv", index=False
    )
    summary = {
        "coverage_start_dbm": -95.0,
        "coverage_end_dbm": -92.5,
        "components_end": 2,
        "max_hops_end": 1,
        "median_stage_ms": 250.0,
        "bytes_per_robot_stage": 100.0,
        "olsr_bytes_per_robot_stage": 20.0,
    }
    (folder / "summary.json").write_text(json.dumps(summary))
    (folder / "swarm.csv").write_text("t,components\n10.0,1\n")


def test_links_lost_are_the_take_off_links_that_the_end_positions_no_longer_hold(tmp_path):
    # Friis at 5.15 GHz, 16.02 dBm, -82 dBm threshold: links up to 368.84 m
    # (docs/reference.md section 2).
    config = resolve_scenario("coverage-large", ("swarm.n_robots=3",))
    first = [(0.0, 0.0), (300.0, 0.0), (600.0, 0.0)]  # a line: links 0-1 and 1-2
    last = [(0.0, 0.0), (360.0, 0.0), (900.0, 0.0)]  # 0-1 kept, 1-2 lost (540 m)
    _fake_run(tmp_path / "run", first, last)
    m = run_measures(tmp_path / "run", config)
    assert list(m) == list(MEASURES)
    assert (m["links_start"], m["links_end"], m["links_lost"]) == (2, 1, 1)
    assert m["links_lost_share"] == 0.5
    assert m["coverage_gain_db"] == 2.5 and m["median_stage_s"] == 0.25
    assert (m["components_start"], m["components_end"]) == (1, 2)
    # a link formed during the mission does not make up for a lost one
    _fake_run(tmp_path / "swap", first, [(0.0, 0.0), (900.0, 0.0), (300.0, 0.0)])  # 0-2 new
    swap = run_measures(tmp_path / "swap", config)
    assert (swap["links_start"], swap["links_end"], swap["links_lost"]) == (2, 1, 2)


def _stages(*stages):
    return [np.array([(x, y, 30.0) for x, y in pos]) for pos in stages]


def test_a_lost_link_of_the_relative_neighbourhood_graph_and_a_split_are_counted():
    # Links up to 368.84 m (Friis, docs/reference.md section 2). A line 0-1-2: both links are
    # relative neighbour links; the second stage loses 1-2 and splits the line in two.
    model = PropagationModel()
    line = run_connectivity(
        _stages([(0, 0), (300, 0), (600, 0)], [(0, 0), (300, 0), (700, 0)]), model
    )
    assert (line["links_lost"], line["spanning_links_lost"], line["splits"]) == (1, 1, 1)
    # A triangle whose long side 0-1 has the witness 2 (closer to both ends): losing 0-1
    # keeps the triangle whole, and the link was not one of the graph's.
    tri = run_connectivity(
        _stages([(0, 0), (300, 0), (150, 100)], [(0, 0), (380, 0), (150, 100)]), model
    )
    assert (tri["links_lost"], tri["spanning_links_lost"], tri["splits"]) == (1, 0, 0)
    # Two groups joining, then parting: one split, counted at the stage where it happens;
    # the links lost and formed between stages add up, the take-off's links are all kept.
    apart, joined = [(0, 0), (300, 0), (1000, 0)], [(0, 0), (300, 0), (600, 0)]
    meet = run_connectivity(_stages(apart, joined, apart, joined), model)
    assert (meet["links_lost"], meet["spanning_links_lost"], meet["splits"]) == (0, 1, 1)


def test_relative_neighbours_match_the_definition_by_brute_force():
    # G. T. Toussaint, Pattern Recognition 12(4), 1980: (i, j) is an edge when no third point
    # is closer to both; here over the links of the radio range, every robot a witness.
    rng = np.random.default_rng(3)
    for n in (2, 5, 40):
        pos = np.column_stack([rng.uniform(0, 900, (n, 2)), np.full(n, 30.0)])
        g = link_graph(pos)
        got = relative_neighbours(pos, g.i, g.j, g.indptr, g.indices)
        d = np.linalg.norm(pos[:, None] - pos[None], axis=2)
        want = [
            not any(max(d[i, m], d[j, m]) < d[i, j] for m in range(n) if m not in (i, j))
            for i, j in zip(g.i, g.j, strict=True)
        ]
        assert got.tolist() == want


@pytest.fixture(scope="module")
def tiny_base():
    return resolve_scenario("coverage-large", TINY)


@pytest.fixture(scope="module")
def study(tiny_base, tmp_path_factory):
    out = tmp_path_factory.mktemp("covs") / "study"
    res = reproduce_coverage_scale(out, sizes=(7, 12), seeds=(0, 1), base=tiny_base, jobs=1)
    return out, res


def test_the_study_writes_its_tables_and_figure(study):
    out, _ = study
    names = {p.name for p in out.iterdir()}
    assert {"runs.csv", "aggregate.csv", "paired.csv", "coverage-scale.png", "study.json"} <= names
    assert {"n7", "n12"} <= names
    runs = pd.read_csv(out / "runs.csv")
    assert list(runs.columns) == [
        "n_robots",
        "variant",
        "seed",
        "status",
        "error",
        "folder",
        *MEASURES,
    ]
    assert (runs["status"] == "complete").all()
    assert sorted(zip(runs["n_robots"], runs["variant"], runs["seed"], strict=True)) == sorted(
        (n, v, s) for n in (7, 12) for v in coverage_scale.VARIANTS for s in (0, 1)
    )
    for row in runs.itertuples():
        config = json.loads((out / row.folder / "summary.json").read_text())
        assert config["n_robots"] == row.n_robots and config["seed"] == row.seed
        assert config["controller"] == ("lloyd" if row.variant == "lloyd" else "game")
    assert (runs["coverage_gain_db"] == runs["coverage_end_dbm"] - runs["coverage_start_dbm"]).all()
    assert (runs["links_lost"] <= runs["links_start"]).all()
    agg = pd.read_csv(out / "aggregate.csv")
    assert list(agg.columns) == [
        "n_robots",
        "variant",
        "metric",
        "n",
        "mean",
        "std",
        "ci_low",
        "ci_high",
    ]
    assert set(agg["variant"]) == {*coverage_scale.VARIANTS, "game - lloyd", "game - game-nolink"}
    assert set(agg["metric"]) == set(MEASURES) and (agg["n"] == 2).all()
    paired = pd.read_csv(out / "paired.csv")
    assert list(paired.columns) == ["n_robots", "comparison", "seed", *MEASURES]


def test_paired_differences_are_the_differences_of_the_runs_and_aggregate_describes_them(study):
    out, res = study
    runs = res.runs.set_index(["n_robots", "variant", "seed"])
    paired = pd.read_csv(out / "paired.csv")
    assert len(paired) == 2 * 2 * 2
    for row in paired.to_dict("records"):
        a, b = row["comparison"].split(" - ")
        for m in MEASURES:
            left, right = (
                runs.loc[(row["n_robots"], a, row["seed"]), m],
                runs.loc[(row["n_robots"], b, row["seed"]), m],
            )
            assert row[m] == pytest.approx(left - right, nan_ok=True)
    agg = res.aggregate().set_index(["n_robots", "variant", "metric"])
    diffs = paired[(paired["n_robots"] == 12) & (paired["comparison"] == "game - lloyd")]
    assert agg.loc[(12, "game - lloyd", "coverage_end_dbm"), "mean"] == pytest.approx(
        diffs["coverage_end_dbm"].mean()
    )


def test_a_run_removed_is_run_again_and_the_others_are_read(study, tiny_base, monkeypatch):
    import shutil

    out, res = study
    removed = res.runs.loc[
        (res.runs["variant"] == "lloyd") & (res.runs["n_robots"] == 12), "folder"
    ].iloc[0]
    shutil.rmtree(out / removed)
    ran = []
    real = executors.execute
    monkeypatch.setattr(executors, "execute", lambda task: ran.append(task.folder) or real(task))
    again = reproduce_coverage_scale(out, sizes=(7, 12), seeds=(0, 1), base=tiny_base, jobs=1)
    assert [p.split("/study/")[-1] for p in ran] == [removed]
    assert (again.runs["status"] == "complete").all()
    cols = ["n_robots", "variant", "seed", "coverage_end_dbm", "links_lost"]
    pd.testing.assert_frame_equal(again.runs[cols], res.runs[cols])
    ran.clear()
    reproduce_coverage_scale(out, sizes=(7,), seeds=(0,), base=tiny_base, jobs=1)
    assert ran == []


def test_a_folder_of_another_study_or_of_something_else_is_refused(study, tmp_path):
    out, _ = study
    other = parse_config({**to_data(resolve_scenario("coverage-large", TINY)), "name": "other"})
    with pytest.raises(RunFolderError, match="study of another scenario"):
        reproduce_coverage_scale(out, sizes=(7,), seeds=(0,), base=other)
    (tmp_path / "x.txt").write_text("mine")
    with pytest.raises(RunFolderError, match="holds no coverage-scale study"):
        reproduce_coverage_scale(tmp_path, sizes=(7,), seeds=(0,))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.txt"]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"sizes": ()}, "sizes: must be a non-empty list"),
        ({"sizes": (7, 7)}, "sizes: must be a non-empty list without repeats"),
        ({"sizes": (0,)}, r"sizes: must be integers >= 1 \(got \(0,\)\)"),
        ({"seeds": (-1,)}, r"seeds must be a non-empty list of integers >= 0 \(got \[-1\]\)"),
        ({"variants": ("game", "mpc")}, "variants: must be some of game, game-nolink, lloyd"),
        ({"base": resolve_scenario("flocking")}, "coverage-scale runs the coverage mission"),
        ({"base": resolve_scenario("coverage")}, "coverage.area_per_robot_m2: .* must be set"),
    ],
)
def test_bad_arguments_are_refused_before_anything_is_written(kwargs, match, tmp_path):
    with pytest.raises(ConfigError, match=match):
        reproduce_coverage_scale(tmp_path / "s", **{"sizes": (7,), "seeds": (0,), **kwargs})
    assert not (tmp_path / "s").exists()


def test_the_command_line(tmp_path):
    runner = CliRunner()
    out = tmp_path / "cli"
    args = [
        "reproduce",
        "coverage-scale",
        "--sizes",
        "7",
        "--seeds",
        "0",
        "--variants",
        "game,lloyd",
    ]
    sets = ["--set", TINY[0], "--set", TINY[1], "--jobs", "1"]
    res = runner.invoke(cli, [*args, *sets, "--out", str(out), "--no-progress"])
    assert res.exit_code == 0, res.output
    assert "2 runs: 2 complete" in res.output
    assert set(pd.read_csv(out / "paired.csv")["comparison"]) == {"game - lloyd"}
    for option, value, shown in [
        ("--sizes", "7,x", "--sizes"),
        ("--sizes", "0", "--sizes"),
        ("--seeds", "0,-1", "--seeds"),
        ("--variants", "game,maybe", "variants: must be some of"),
        ("--address", "auto", "--address: is a Ray cluster's"),
    ]:
        bad = runner.invoke(cli, [*args[:2], option, value, "--out", str(tmp_path / "b")])
        assert bad.exit_code == 2 and shown in bad.output, bad.output
        assert len(bad.output.strip().splitlines()) == 1
    assert not (tmp_path / "b").exists()
