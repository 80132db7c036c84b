"""Run folders: atomic writes and the --force rule."""

from __future__ import annotations

import os

import pandas as pd
import pytest

from swarmgames.errors import RunFolderError
from swarmgames.runfolder import LOCK_FILE, RunFolder, atomic_open, atomic_write_text


def test_interrupted_write_leaves_no_partial_file(tmp_path):
    target = tmp_path / "data.csv"
    with pytest.raises(RuntimeError, match="boom"), atomic_open(target) as fh:
        fh.write("t,x\n0,1\n")
        raise RuntimeError("boom")
    assert not target.exists()
    assert list(tmp_path.iterdir()) == []  # no temporary file left behind either


def test_interrupted_write_keeps_previous_content(tmp_path):
    target = atomic_write_text(tmp_path / "a.txt", "old")
    with pytest.raises(KeyboardInterrupt), atomic_open(target) as fh:
        fh.write("new but incomplete")
        raise KeyboardInterrupt
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["a.txt"]


def test_existing_non_empty_folder_needs_force(tmp_path):
    (tmp_path / "old.txt").write_text("keep me")
    with pytest.raises(RunFolderError, match="not empty; use --force"):
        RunFolder(tmp_path)
    run = RunFolder(tmp_path, force=True)
    run.write_text("new.txt", "x")
    assert (tmp_path / "old.txt").read_text() == "keep me"


def test_empty_existing_folder_is_fine(tmp_path):
    RunFolder(tmp_path).write_text("a.txt", "a")
    assert (tmp_path / "a.txt").read_text() == "a"


def test_path_that_is_a_file_is_rejected(tmp_path):
    f = tmp_path / "f"
    f.write_text("")
    with pytest.raises(RunFolderError, match="not a folder"):
        RunFolder(f, force=True)


def test_writers(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    run = RunFolder(tmp_path / "r")
    run.write_csv("d.csv", pd.DataFrame({"t": [0.0, 1.0], "x": [1, 2]}))
    run.write_json("s.json", {"a": np.float64(1.5), "b": np.arange(2)})
    fig, ax = plt.subplots()
    ax.plot([0, 1])
    run.save_figure("f.png", fig)
    plt.close(fig)
    assert (tmp_path / "r" / "d.csv").read_text() == "t,x\n0.0,1\n1.0,2\n"
    assert '"a": 1.5' in (tmp_path / "r" / "s.json").read_text()
    assert (tmp_path / "r" / "f.png").read_bytes()[:4] == b"\x89PNG"
    assert len(run.written) == 3


def test_file_names_cannot_escape(tmp_path):
    run = RunFolder(tmp_path / "r")
    with pytest.raises(ValueError, match="inside the run folder"):
        run.write_text("../escape.txt", "x")


def test_files_get_ordinary_permissions(tmp_path):
    import os
    import stat

    mask = os.umask(0o022)
    try:
        p = atomic_write_text(tmp_path / "a.txt", "x")
    finally:
        os.umask(mask)
    assert stat.S_IMODE(p.stat().st_mode) == 0o644


def test_leftover_temporary_file_does_not_block_a_rerun(tmp_path):
    # What kill -9 during atomic_open leaves behind: mkstemp's ".<name>.<random>.tmp".
    leftover = tmp_path / ".trajectory.csv.k3j9x2ab.tmp"
    leftover.write_text("t,x\n0,")
    RunFolder(tmp_path).write_text("a.txt", "a")  # counts as empty
    names = sorted(p.name for p in tmp_path.iterdir() if p.name != LOCK_FILE)
    assert names == ["a.txt"]  # and is cleaned up


def test_leftover_is_removed_when_reused_with_force(tmp_path):
    (tmp_path / "old.txt").write_text("keep me")
    (tmp_path / ".summary.json.abc.tmp").write_text("{")
    with pytest.raises(RunFolderError, match="not empty"):
        RunFolder(tmp_path)
    RunFolder(tmp_path, force=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == [LOCK_FILE, "old.txt"]


def test_an_ordinary_hidden_file_still_counts(tmp_path):
    (tmp_path / ".notes").write_text("mine")
    with pytest.raises(RunFolderError, match="not empty"):
        RunFolder(tmp_path)


def test_discard_removes_only_the_folders_it_created(tmp_path):
    mine = tmp_path / "mine"
    mine.mkdir()
    RunFolder(mine).discard_if_empty()
    assert mine.is_dir()  # existed before: kept although empty
    run = RunFolder(tmp_path / "a" / "b")
    assert run.created == [tmp_path / "a", tmp_path / "a" / "b"]
    run.discard_if_empty()
    assert not (tmp_path / "a").exists()


def test_discard_keeps_a_folder_with_files(tmp_path):
    run = RunFolder(tmp_path / "r")
    run.write_text("a.txt", "a")
    run.discard_if_empty()
    assert (tmp_path / "r" / "a.txt").exists()


def test_folder_below_a_file_is_one_error(tmp_path):
    (tmp_path / "f").write_text("")
    with pytest.raises(RunFolderError, match=r"cannot write into output folder .*f[/\\]run"):
        RunFolder(tmp_path / "f" / "run")


@pytest.mark.skipif(
    not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root writes into read-only folders"
)
def test_read_only_place_is_one_error(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        with pytest.raises(RunFolderError, match="cannot write into output folder"):
            RunFolder(ro / "run")
        with pytest.raises(RunFolderError, match="cannot write into output folder"):
            RunFolder(ro)  # exists and is empty, but nothing can be written there
    finally:
        ro.chmod(0o755)


def test_unwritable_folder_is_one_error(tmp_path, monkeypatch):
    # The read-only case as root sees it too: whatever stops the probe file is reported.
    import swarmgames.runfolder as runfolder

    def refuse(folder):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(runfolder, "_check_writable", refuse)
    with pytest.raises(
        RunFolderError, match=r"cannot write into output folder .*Permission denied"
    ):
        RunFolder(tmp_path / "new" / "run")
    assert not (tmp_path / "new").exists()  # what it created for nothing is gone again


def _disk_full_on(monkeypatch, name: str) -> None:
    """Make every fsync of a temporary file for ``name`` fail as on a full disk."""
    import errno

    real_fsync, real_fdopen = os.fsync, os.fdopen
    doomed: set[int] = set()

    def fdopen(fd, *args, **kwargs):
        fh = real_fdopen(fd, *args, **kwargs)
        if f".{name}." in os.readlink(f"/proc/self/fd/{fd}"):
            doomed.add(fd)
        return fh

    def fsync(fd):
        if fd in doomed:
            raise OSError(errno.ENOSPC, "No space left on device")
        return real_fsync(fd)

    monkeypatch.setattr(os, "fdopen", fdopen)
    monkeypatch.setattr(os, "fsync", fsync)


@pytest.mark.skipif(not os.path.exists("/proc/self/fd"), reason="needs /proc/self/fd")
def test_a_failed_write_is_one_error_naming_the_file_and_leaves_nothing(tmp_path, monkeypatch):
    from swarmgames.errors import OutputWriteError

    _disk_full_on(monkeypatch, "a.txt")
    folder = RunFolder(tmp_path / "run")
    with pytest.raises(OutputWriteError, match=r"cannot write .*a\.txt: No space left on device"):
        folder.write_text("a.txt", "hello")
    assert [p.name for p in (tmp_path / "run").iterdir()] == [LOCK_FILE]
    assert isinstance(OutputWriteError("x"), OSError)


def test_a_folder_that_cannot_be_created_is_an_output_write_error(tmp_path):
    from swarmgames.errors import OutputWriteError

    (tmp_path / "file").write_text("x")
    with pytest.raises(OutputWriteError, match=r"cannot write .*file.*"):
        atomic_write_text(tmp_path / "file" / "inner.txt", "x")


@pytest.mark.skipif(not os.path.exists("/proc/self/fd"), reason="needs /proc/self/fd")
def test_cli_run_with_a_full_disk_exits_1_with_one_line(tmp_path, monkeypatch):
    from click.testing import CliRunner

    from swarmgames.cli import cli

    _disk_full_on(monkeypatch, "summary.json")
    res = CliRunner().invoke(
        cli,
        [
            "run",
            "--out",
            str(tmp_path / "run"),
            "--no-progress",
            "--set",
            "sim.duration_s=2",
            "--set",
            "sim.animation=false",
        ],
    )
    assert res.exit_code == 1, res.output
    assert res.output.startswith("Error: cannot write ") and "No space left on device" in res.output
    assert len(res.output.strip().splitlines()) == 1 and "Traceback" not in res.output


def test_an_appended_table_on_a_full_disk_keeps_whole_chunks_and_says_so(tmp_path, monkeypatch):
    import errno

    from swarmgames.errors import OutputWriteError
    from swarmgames.runfolder import AppendFile

    table = AppendFile(tmp_path / "metrics.csv")
    table.append(b"t,robot\n0,1\n")
    real_write = os.write

    def write(fd, data):  # half of the chunk fits, then the disk is full
        if fd == table._fd and len(data) > 4:
            real_write(fd, bytes(data[:4]))
            raise OSError(errno.ENOSPC, "No space left on device")
        return real_write(fd, data)

    monkeypatch.setattr(os, "write", write)
    with pytest.raises(OutputWriteError, match=r"cannot write .*metrics.csv: No space left"):
        table.append(b"1,1\n2,1\n")
    monkeypatch.undo()
    table.close()
    assert (tmp_path / "metrics.csv").read_bytes() == b"t,robot\n0,1\n"


def test_a_second_writer_is_refused_naming_the_holder(tmp_path):
    first = RunFolder(tmp_path / "run")
    with pytest.raises(RunFolderError, match=rf"another swarmgames process \(pid {os.getpid()} "):
        RunFolder(tmp_path / "run", force=True)
    first.close()
    RunFolder(tmp_path / "run", force=True).close()  # released: the next writer may


def test_the_lock_of_a_killed_process_never_blocks_a_rerun(tmp_path):
    import signal
    import subprocess
    import sys

    code = (
        "import sys, time\n"
        "from swarmgames.runfolder import RunFolder\n"
        "folder = RunFolder(sys.argv[1])\n"
        "print('locked', flush=True)\n"
        "time.sleep(60)\n"
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", code, str(tmp_path / "run")], stdout=subprocess.PIPE, text=True
    )
    try:
        assert proc.stdout.readline().strip() == "locked"
        with pytest.raises(RunFolderError, match=rf"pid {proc.pid} "):
            RunFolder(tmp_path / "run", force=True)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        proc.kill()
    RunFolder(tmp_path / "run", force=True).close()
