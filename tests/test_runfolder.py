"""Run folders: atomic writes and the --force rule."""

from __future__ import annotations

import pandas as pd
import pytest

from swarmgames.errors import RunFolderError
from swarmgames.runfolder import RunFolder, atomic_open, atomic_write_text


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
