"""Run folders from elsewhere: resume, a sweep that reuses them and RunResult.load never run
code from them, and a folder that does not match its manifest is one line, exit 2."""

import contextlib
import hashlib
import json
import pickle
from pathlib import Path

import pytest
from click.testing import CliRunner

import swarmgames
from swarmgames.cli import cli
from swarmgames.config import parse_config
from swarmgames.errors import RunFolderError
from swarmgames.sim import RunResult, build_mission, resume, run

from .test_resume import StopAfter

SMALL = {
    "name": "small",
    "swarm": {"n_robots": 4},
    "sim": {"duration_s": 6.0, "warmup_s": 2.0, "animation": False},
}


class Planted:
    """A pickle that writes ``marker`` when it is loaded."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return (Path.write_text, (self.marker, "code from the folder ran"))


def _interrupted(tmp_path: Path) -> Path:
    cfg = parse_config(SMALL)
    out = tmp_path / "run"
    run(cfg, out=out, progress=False, mission=StopAfter(build_mission(cfg), 3))
    manifest = json.loads((out / "manifest.json").read_text())
    manifest["custom_mission"] = False  # as the CLI writes it (a registered mission)
    (out / "manifest.json").write_text(json.dumps(manifest))
    return out


def _checkpoint_files(out: Path) -> list[str]:
    names = sorted(p.name for p in (out / "checkpoint").iterdir())
    # The names a checkpoint has, and those the pickles of earlier versions had.
    return [*names, "state.pickle", "stages.pickle"]


def _plant(out: Path, name: str, marker: Path, vouch: bool) -> None:
    payload = pickle.dumps(Planted(marker))
    (out / "checkpoint" / name).write_bytes(payload)
    if vouch:  # the manifest edited to vouch for the planted file
        manifest = json.loads((out / "manifest.json").read_text())
        entry = {"bytes": len(payload), "sha256": hashlib.sha256(payload).hexdigest()}
        rel = f"checkpoint/{name}"
        if manifest["records"] is not None and rel.endswith(".npzs"):
            manifest["records"] = entry
            manifest["checkpoint"]["records"] = entry
        else:
            manifest["checkpoint"].update(entry, file=rel)
        (out / "manifest.json").write_text(json.dumps(manifest))


@pytest.mark.parametrize("vouch", [False, True], ids=["file", "file-and-manifest"])
def test_planted_pickles_never_run_on_resume_or_load(tmp_path, vouch):
    clean = _interrupted(tmp_path)
    names = _checkpoint_files(clean)
    assert {n.rsplit(".", 1)[-1] for n in names} >= {"npz", "npzs", "pickle"}
    marker = tmp_path / "marker"
    runner = CliRunner()
    for k, name in enumerate(names):
        out = tmp_path / f"copy{k}"
        out.mkdir()
        for p in clean.rglob("*"):
            if p.is_file():
                (out / p.relative_to(clean)).parent.mkdir(exist_ok=True)
                (out / p.relative_to(clean)).write_bytes(p.read_bytes())
        _plant(out, name, marker, vouch)
        res = runner.invoke(cli, ["run", "--resume", str(out), "--no-progress"])
        if name.endswith(".pickle") and not vouch:  # a file no manifest names is not read
            assert res.exit_code == 0, res.output
        else:
            assert res.exit_code == 2, (name, res.output)
            assert "Traceback" not in res.output
            lines = res.output.strip().splitlines()
            assert len(lines) == 1 and "checkpoint" in lines[0], res.output
        assert not marker.exists(), name
        with contextlib.suppress(RunFolderError):  # load reads tables and JSON only
            RunResult.load(out)
        assert not marker.exists(), name


def test_a_sweep_resuming_a_tampered_run_runs_no_code_and_reruns_it(tmp_path):
    marker = tmp_path / "marker"
    out = tmp_path / "sweep"
    first = swarmgames.sweep(parse_config(SMALL), {}, seeds=[0, 1], jobs=1, out=out)
    folder = out / first["folder"].iloc[0]
    manifest = json.loads((folder / "manifest.json").read_text())
    payload = pickle.dumps(Planted(marker))
    (folder / "checkpoint").mkdir()
    (folder / "checkpoint" / "state-000002.npz").write_bytes(payload)
    entry = {"bytes": len(payload), "sha256": hashlib.sha256(payload).hexdigest()}
    manifest.update(  # set back to running, with a checkpoint it vouches for
        status="running",
        resumable=True,
        checkpoint_stage=2,
        checkpoint={"file": "checkpoint/state-000002.npz", **entry, "tables": {}},
    )
    (folder / "manifest.json").write_text(json.dumps(manifest))
    again = swarmgames.sweep(parse_config(SMALL), {}, seeds=[0, 1], jobs=1, out=out)
    assert not marker.exists()
    assert (again["status"] == "complete").all()
    assert "names no valid checkpoint" in again.attrs["rerun"][first["folder"].iloc[0]]
    assert again.drop(columns=[c for c in again if "ms" in c or c == "wall_s"]).equals(
        first.drop(columns=[c for c in first if "ms" in c or c == "wall_s"])
    )


def test_resume_reads_the_checkpoint_of_the_manifest_not_a_later_one(tmp_path):
    # A run killed between writing a checkpoint and the manifest naming it resumes from the
    # checkpoint the manifest names.
    out = _interrupted(tmp_path)
    manifest = json.loads((out / "manifest.json").read_text())
    later = out / "checkpoint" / "state-000099.npz"
    later.write_bytes(b"half written")
    resume(out, progress=False)
    assert json.loads((out / "manifest.json").read_text())["status"] == "complete"
    assert manifest["checkpoint"]["file"] == "checkpoint/state-000003.npz"


def test_a_table_that_is_a_link_is_refused_and_its_target_untouched(tmp_path):
    out = _interrupted(tmp_path)
    outside = tmp_path / "outside.csv"
    outside.write_bytes((out / "swarm.csv").read_bytes())
    (out / "swarm.csv").unlink()
    (out / "swarm.csv").symlink_to(outside)
    before = outside.read_bytes()
    res = CliRunner().invoke(cli, ["run", "--resume", str(out), "--no-progress"])
    assert res.exit_code == 2 and "swarm.csv is a link" in res.output, res.output
    assert outside.read_bytes() == before
