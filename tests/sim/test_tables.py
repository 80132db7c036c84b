"""The tables' formats (csv, csv.gz, Parquet), read back by RunResult.load, kept whole stage
by stage and resumed; the animation and figures of large swarms."""

import gzip
import json

import numpy as np
import pandas as pd
import pytest

from swarmgames.config import parse_config
from swarmgames.errors import InputDataError, RunFolderError
from swarmgames.runfolder import RunFolder
from swarmgames.sim import RunResult, build_mission, resume, run
from swarmgames.sim import tables as tables_module
from swarmgames.sim.journal import read_manifest
from swarmgames.sim.tables import LARGE_ROWS, choose_format, read_table

from .test_resume import StopAfter

pytest.importorskip("pyarrow", reason='pip install "swarmgames[parquet]"')

BASE = {
    "name": "small",
    "swarm": {"n_robots": 5},
    "sim": {"duration_s": 8.0, "warmup_s": 3.0, "animation": False},
}


def _config(**sim):
    data = json.loads(json.dumps(BASE))
    data["sim"].update(sim)
    return parse_config(data)


def _tables(result):
    return {name: result.to_frame(name) for name in ("trajectory", "metrics", "swarm")}


TIMINGS = ["solve_ms", "integrate_ms", "refine_ms"]


@pytest.fixture(scope="module")
def plain(tmp_path_factory):
    out = tmp_path_factory.mktemp("csv") / "run"
    return run(_config(tables="csv"), out=out, progress=False), out


@pytest.mark.parametrize("fmt", ["csv.gz", "parquet"])
def test_every_format_holds_the_same_tables(tmp_path, plain, fmt):
    ref, ref_dir = plain
    res = run(_config(tables=fmt), out=tmp_path / "run", progress=False)
    m = read_manifest(tmp_path / "run")
    assert m["tables_format"] == fmt
    assert (tmp_path / "run" / f"metrics.{fmt}").exists()
    assert not (tmp_path / "run" / "metrics.csv").exists()
    loaded = RunResult.load(tmp_path / "run")
    for name, frame in _tables(loaded).items():
        want = ref.to_frame(name).drop(columns=TIMINGS, errors="ignore")
        got = frame.drop(columns=TIMINGS, errors="ignore")
        pd.testing.assert_frame_equal(got, want, check_exact=True, check_dtype=fmt != "csv.gz")
        pd.testing.assert_frame_equal(
            res.to_frame(name).drop(columns=TIMINGS, errors="ignore"), want, check_exact=True
        )
    assert loaded.summary["stages"] == 8 and loaded.summary == json.loads(
        (tmp_path / "run" / "summary.json").read_text()
    )
    if fmt == "csv.gz":  # one gzip member per stage; the text is that of the csv format
        text = gzip.decompress((tmp_path / "run" / "trajectory.csv.gz").read_bytes())
        assert text == (ref_dir / "trajectory.csv").read_bytes()
    else:  # a Parquet dataset, one part per stage (the trajectory has one more: the end)
        parts = sorted((tmp_path / "run" / "swarm.parquet").iterdir())
        assert [p.name for p in parts][:2] == ["part-000000.parquet", "part-000001.parquet"]
        assert (
            len(parts) == 8 and len(list((tmp_path / "run" / "trajectory.parquet").iterdir())) == 9
        )
        assert pd.read_parquet(tmp_path / "run" / "swarm.parquet").shape[0] == 8


@pytest.mark.parametrize("fmt", ["csv.gz", "parquet"])
def test_interrupted_then_resumed_in_every_format(tmp_path, fmt):
    cfg = _config(tables=fmt)
    run(cfg, out=tmp_path / "full", progress=False)
    out = tmp_path / "run"
    run(cfg, out=out, progress=False, mission=StopAfter(build_mission(cfg), 3))
    m = read_manifest(out)
    assert m["status"] == "interrupted" and m["tables"][f"swarm.{fmt}"]["rows"] == 3
    assert len(read_table(out, "swarm")) == 3  # readable while interrupted
    resume(out, progress=False, mission=build_mission(cfg))
    for name in ("trajectory", "swarm"):
        pd.testing.assert_frame_equal(
            read_table(out, name), read_table(tmp_path / "full", name), check_exact=True
        )
    if fmt == "csv.gz":  # gzip members without timestamps: the same run, the same bytes
        for name in ("trajectory.csv.gz", "swarm.csv.gz"):
            assert (out / name).read_bytes() == (tmp_path / "full" / name).read_bytes()


def test_auto_picks_csv_for_small_runs_and_a_compact_format_for_large(monkeypatch):
    assert choose_format("auto", 7, 90) == "csv"
    big = LARGE_ROWS  # robots x (stages + 1) above the limit
    assert choose_format("auto", big, 1) == "parquet"
    monkeypatch.setattr(tables_module, "has_pyarrow", lambda: False)
    assert choose_format("auto", big, 1) == "csv.gz"
    with pytest.raises(RunFolderError, match=r"pip install \"swarmgames\[parquet\]\""):
        choose_format("parquet", 7, 90)


def test_a_rerun_with_force_in_another_format_leaves_one_version(tmp_path):
    run(_config(tables="csv"), out=tmp_path / "run", progress=False)
    run(_config(tables="parquet"), out=RunFolder(tmp_path / "run", force=True), progress=False)
    names = {p.name for p in (tmp_path / "run").iterdir()}
    assert "metrics.parquet" in names and "metrics.csv" not in names
    run(_config(tables="csv.gz"), out=RunFolder(tmp_path / "run", force=True), progress=False)
    names = {p.name for p in (tmp_path / "run").iterdir()}
    assert "metrics.csv.gz" in names and "metrics.parquet" not in names


def test_load_names_what_it_cannot_read(tmp_path, plain):
    _, ref_dir = plain
    with pytest.raises(InputDataError, match="has no swarm table"):
        read_table(tmp_path, "swarm")
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "swarm.csv.gz").write_bytes(b"not gzip")
    with pytest.raises(InputDataError, match=r"cannot read .*swarm.csv.gz"):
        read_table(bad, "swarm")
    loaded = RunResult.load(ref_dir)
    assert loaded.links == [] and loaded.plot_paths() is not None  # no links kept: none drawn


def test_large_swarm_animation_shows_density_and_respects_the_size_cap():
    from swarmgames.sim.animation import render_gif

    class Fake:
        pass

    n, s = 400, 5
    rng = np.random.default_rng(0)
    xy = rng.normal(0, 500, (s + 1, n, 2))
    fake = Fake()
    fake.trajectory = pd.DataFrame(
        {
            "t": np.repeat(np.arange(s + 1.0), n),
            "robot": np.tile(np.arange(n), s + 1),
            "x": xy[..., 0].ravel(),
            "y": xy[..., 1].ravel(),
        }
    )
    alive = np.ones((s, n), dtype=bool)
    alive[2:, :10] = False  # ten crash
    fake.metrics = pd.DataFrame({"alive": alive.ravel(), "radio": alive.ravel()})
    fake.swarm = pd.DataFrame({"t": np.arange(s, dtype=float)})
    fake.links = [np.column_stack([np.arange(n - 1), np.arange(1, n)])] * s
    fake.mission = None
    gif = render_gif(fake, max_frames=5)
    assert gif[:6] == b"GIF89a"
    import io

    from PIL import Image

    assert Image.open(io.BytesIO(gif)).n_frames == 5
    small = render_gif(fake, max_frames=5, max_bytes=len(gif) // 2)
    assert Image.open(io.BytesIO(small)).n_frames < 5 and len(small) < len(gif)
