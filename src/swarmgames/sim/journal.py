"""The journal of a run folder: each completed stage kept at once, checkpoints, a manifest.

While a run goes on, its folder holds

* ``config.toml``, written before the first stage;
* the tables ``trajectory``, ``metrics`` and ``swarm`` (CSV, gzip-compressed CSV or Parquet:
  :mod:`swarmgames.sim.tables`), to which every completed stage is appended whole, so that a
  killed run leaves every stage it completed readable;
* ``manifest.json``, rewritten (atomically) after every stage: the run's status, the stages
  completed, the rows, bytes and SHA-256 of each table, of the stage records and of every
  other file, whether and from where the run can be resumed;
* ``checkpoint/stages.npzs``: every stage record, exact (the tables' values and the links of
  the routing tables), appended like the tables as frames of ``.npz`` archives
  (:mod:`swarmgames.sim.datafile`); from it the summary, the figures and the animation can
  be rebuilt whatever stopped the run;
* ``checkpoint/state-<stage>.npz``: the stage loop's state
  (:class:`~swarmgames.sim.loop.LoopState`: states, random states, the network provider's and
  the communication model's state), every ``sim.checkpoint_every`` stages, with the sizes the
  tables had then. The manifest names the current one; the one before is removed only once
  the manifest names the new one, so that a run killed at any moment has a checkpoint its
  manifest vouches for.

At the end come ``summary.json``, the figures and the animation; the manifest then says
``complete`` and ``checkpoint/`` is removed. ``swarmgames run --resume DIR`` cuts the tables
back to the last checkpoint, restores the loop and goes on: the run ends bit for bit as an
uninterrupted run would (wall times aside).

Every file is data (JSON, CSV, Parquet, ``.npz`` read with ``allow_pickle=False``): reading a
run folder never runs code from it. Before anything of a folder is read back (a resume, a
sweep that reuses it, :meth:`~swarmgames.sim.result.RunResult.load`), its files are checked
against the SHA-256 its manifest holds (:func:`verify_run`); a file that does not match is
refused with one line naming it.
"""

from __future__ import annotations

import contextlib
import json
import shutil
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from swarmgames.errors import RunFolderError
from swarmgames.network.provider import SnapshotUnsupported
from swarmgames.runfolder import sha256_file
from swarmgames.sim import datafile
from swarmgames.sim.loop import LoopState, StageLog, StageRecord
from swarmgames.sim.signals import deferred_interrupts
from swarmgames.sim.tables import (
    TABLE_NAMES,
    choose_format,
    open_table,
    remove_stale,
    table_file,
    table_sha256,
)

__all__ = [
    "MANIFEST",
    "Checkpoint",
    "RunJournal",
    "read_checkpoint",
    "read_manifest",
    "read_records",
    "verify_run",
]

MANIFEST = "manifest.json"
CHECKPOINT_DIR = "checkpoint"
RECORDS = f"{CHECKPOINT_DIR}/stages.npzs"
#: Version of the journal's files; a folder of another version is not resumed.
FORMAT = 2


def _state_file(stage: int) -> str:
    return f"{CHECKPOINT_DIR}/state-{stage:06d}.npz"


@dataclass(frozen=True, eq=False)
class Checkpoint:
    """The content of a ``checkpoint/state-<stage>.npz``.

    Attributes
    ----------
    stage : int
        Stages completed at the checkpoint.
    config : str
        The run's ``config.toml`` text (a resumed run checks it is unchanged).
    loop : LoopState
    sizes : dict of int
        Size of each table (bytes; Parquet: parts) and of the stage records (bytes) at the
        checkpoint.
    rows : dict of int
        Rows of each table at the checkpoint.
    wall_s : float
        Wall time of the run until the checkpoint, s.
    tables : str
        The tables' format.
    """

    stage: int
    config: str
    loop: LoopState
    sizes: dict[str, int]
    rows: dict[str, int]
    wall_s: float
    tables: str


def read_manifest(path) -> dict[str, Any]:
    """The manifest of the run folder at ``path``.

    Raises
    ------
    RunFolderError
        No folder, no manifest, or an unreadable one (one line naming the file).
    """
    path = Path(path)
    if not path.is_dir():
        raise RunFolderError(f"no run folder at {path}")
    file = path / MANIFEST
    try:
        manifest = json.loads(file.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise RunFolderError(
            f"{path} is not a run folder of `swarmgames run` (it has no {MANIFEST})"
        ) from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
        raise RunFolderError(f"cannot read {file}: {str(exc)[:200]}") from None
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
        raise RunFolderError(f"{file} is not a manifest of this swarmgames (format {FORMAT})")
    return manifest


def _entry(path: Path) -> dict[str, Any]:
    return {"bytes": path.stat().st_size, "sha256": sha256_file(path)}


def _check(folder: Path, name: str, entry: Any, fmt: str | None = None) -> None:
    """Raise unless the first ``entry["bytes"]`` bytes (``parts``: Parquet parts) of
    ``folder / name`` have the SHA-256 ``entry["sha256"]``."""
    path = folder / name
    size = entry.get("parts", entry.get("bytes")) if isinstance(entry, dict) else None
    want = entry.get("sha256") if isinstance(entry, dict) else None
    if not isinstance(size, int) or isinstance(size, bool) or size < 0 or not isinstance(want, str):
        raise RunFolderError(f"{folder / MANIFEST} has no valid entry for {name}")
    if path.is_symlink() or not path.resolve().is_relative_to(folder.resolve()):
        raise RunFolderError(f"{path} is a link; a run folder holds its own files")
    try:
        got = table_sha256(path, fmt, size) if fmt else sha256_file(path, size)
    except (OSError, EOFError):
        got = None
    if got != want:
        raise RunFolderError(
            f"{path} does not match the manifest of its run folder (changed, cut short or "
            "missing since the run wrote it)"
        )


def _extent(path: Path, fmt: str) -> int:
    """Bytes of a text table, parts of a Parquet one."""
    if fmt == "parquet":
        return len(list(path.glob("part-*.parquet")))
    return path.stat().st_size


def verify_run(path, manifest: dict[str, Any] | None = None) -> dict[str, Any]:
    """Check every file the manifest of the run folder at ``path`` lists against its SHA-256,
    before anything else of the folder is read; return the manifest.

    The tables and the stage records are checked as far as the manifest knew them (a killed
    run may have appended a stage after its last manifest); a complete run's tables must be
    exactly those. Of a run that stopped before its end, the summary and the figures are not
    checked (a resume writes them again).

    Raises
    ------
    RunFolderError
        Not a run folder, or a file that does not match (one line naming it).
    """
    path = Path(path)
    manifest = read_manifest(path) if manifest is None else manifest
    files, tables = manifest.get("files"), manifest.get("tables")
    if not isinstance(files, dict) or not isinstance(tables, dict) or "config.toml" not in files:
        raise RunFolderError(f"{path / MANIFEST} lists no files to check")
    complete = manifest.get("status") == "complete"
    for name, entry in files.items():
        if complete or name == "config.toml":  # the rest of a stopped run is rewritten
            _check(path, name, entry)
    fmt = manifest.get("tables_format")
    for name, entry in tables.items():
        _check(path, name, entry, fmt)
        if complete and _extent(path / name, fmt) != entry.get("parts", entry.get("bytes")):
            raise RunFolderError(f"{path / name} does not match the manifest of its run folder")
    if manifest.get("records") is not None:
        _check(path, RECORDS, manifest["records"])
    return manifest


class RunJournal:
    """Keeps a run folder up to date stage by stage (see the module docstring).

    Build it with :meth:`begin` (a new run) or :meth:`reopen` (a resumed one); the stage
    loop calls :meth:`stage` after every completed stage (``drive(on_stage=...)``), the
    runner :meth:`finish` or :meth:`fail` at the end.

    Parameters
    ----------
    folder : RunFolder
    manifest : dict
        The manifest's fields that do not change during the run.
    start : ndarray, shape (N, D)
        The states before the first stage.
    every : int
        Checkpoint every this many stages (0: never).
    resumable : str or None
        None when the run can be checkpointed, else why not.
    """

    def __init__(self, folder, manifest, start, every, resumable, config_text, fmt) -> None:
        self.folder = folder
        self.fmt = fmt
        self.manifest = dict(manifest)
        self.start = np.asarray(start, dtype=float)
        self.every = int(every)
        self.why_not = resumable
        self.config_text = config_text
        self.tables: dict[str, Any] = {}
        self.records = None
        self.stages = 0
        self.checkpoint_stage: int | None = None
        self.checkpoint: dict[str, Any] | None = None  # the manifest's entry of it
        self.files: dict[str, Any] = {}  # the manifest's entries of the other files
        self.previous = self.start  # the states before the next stage to append
        self.wall_before = 0.0
        self.t0 = time.perf_counter()

    # ------------------------------------------------------------------ opening
    @classmethod
    def begin(cls, folder, config, loop, start, n_stages: int, *, mission: str, custom: dict):
        """Start the journal of a new run in ``folder`` (after ``loop.start``): write
        ``config.toml``, the first manifest, the records' header and, if the run can be
        resumed, the checkpoint of stage 0."""
        from swarmgames.config import to_toml

        text = to_toml(config)
        fmt = choose_format(config.sim.tables, start.shape[0], n_stages)
        every = int(config.sim.checkpoint_every)
        why = "sim.checkpoint_every = 0" if every == 0 else None
        manifest = {
            "format": FORMAT,
            "scenario": config.name,
            "mission": mission,
            "seed": config.seed,
            "stages_planned": int(n_stages),
            "tables_format": fmt,
            **custom,
        }
        journal = cls(folder, manifest, start, every, why, text, fmt)
        shutil.rmtree(folder.file(CHECKPOINT_DIR), ignore_errors=True)
        journal.files["config.toml"] = _entry(folder.write_text("config.toml", text))
        remove_stale(folder, fmt)
        for name in TABLE_NAMES:
            journal.tables[name] = open_table(folder, name, fmt)
        journal.records = folder.append_file(RECORDS)
        header = {"format": FORMAT, "start": journal.start, "period_s": float(loop.period_s)}
        journal.records.append(datafile.frame(datafile.dumps(header)))
        if why is None:
            try:  # the checkpoint of stage 0 tells whether the run can have any
                journal._checkpoint(loop, 0.0)
            except SnapshotUnsupported as exc:  # ns-3, or a provider without state()
                journal.why_not = str(exc)
        journal._write_manifest("running")
        return journal

    @classmethod
    def reopen(cls, folder, checkpoint: Checkpoint, manifest: dict) -> tuple[RunJournal, list]:
        """Continue the journal of ``folder`` from ``checkpoint``: cut the tables and the
        records back to it and read the records of its completed stages."""
        journal = cls(
            folder,
            manifest,
            np.zeros((0, 0)),
            int(manifest["checkpoint_every"]),
            None,
            checkpoint.config,
            checkpoint.tables,
        )
        journal.files = dict(manifest["files"])
        journal.checkpoint = dict(manifest["checkpoint"])
        sizes = checkpoint.sizes
        for name in TABLE_NAMES:
            journal.tables[name] = open_table(
                folder, name, checkpoint.tables, keep=sizes[name], rows=checkpoint.rows[name]
            )
        journal.records = folder.append_file(RECORDS, keep=sizes[RECORDS])
        header, records = _read_records(folder.file(RECORDS), sizes[RECORDS])
        if len(records) != checkpoint.stage:
            raise RunFolderError(
                f"{folder.file(RECORDS)} holds {len(records)} stages, its checkpoint "
                f"{checkpoint.stage}: the folder was changed after the run stopped"
            )
        journal.start = np.asarray(header["start"], dtype=float)
        journal.previous = records[-1].after if records else journal.start
        journal.stages = journal.checkpoint_stage = checkpoint.stage
        journal.wall_before = checkpoint.wall_s
        journal.t0 = time.perf_counter()
        journal._write_manifest("running")
        return journal, records

    # ------------------------------------------------------------------ stages
    def stage(self, record: StageRecord, loop) -> None:
        """Append ``record`` to the tables and the records, then checkpoint when due and
        rewrite the manifest."""
        from swarmgames.sim.result import _metrics, _swarm, _trajectory

        one = StageLog.from_records(
            self.previous,
            [record],
            interrupted=False,
            wall_s=0.0,
            period_s=loop.period_s,
            warmup_s=loop.warmup_s,
        )
        n = self.start.shape[0]
        frames = {
            "trajectory": _trajectory(one).iloc[:n],
            "metrics": _metrics(one),
            "swarm": _swarm(one),
        }
        for name, frame in frames.items():
            self.tables[name].append(frame)
        self.records.append(datafile.frame(datafile.dumps(record)))
        self.stages += 1
        self.previous = record.after
        if self.why_not is None and self.stages % self.every == 0:
            self._checkpoint(loop, self.wall_before + time.perf_counter() - self.t0)
        self._write_manifest("running")

    def _checkpoint(self, loop, wall_s: float) -> None:
        sizes = {name: f.size for name, f in self.tables.items()}
        sizes[RECORDS] = self.records.size
        point = {
            "format": FORMAT,
            "stage": self.stages,
            "config": self.config_text,
            "loop": loop.state(),
            "sizes": sizes,
            "rows": {name: t.rows for name, t in self.tables.items()},
            "wall_s": float(wall_s),
            "tables": self.fmt,
        }
        name = _state_file(self.stages)
        path = self.folder.write_bytes(name, datafile.dumps(point))
        self.checkpoint = {
            "file": name,
            **_entry(path),
            "tables": self._table_entries(),
            "records": {"bytes": self.records.size, "sha256": self.records.sha256},
        }
        self.checkpoint_stage = self.stages

    def _table_entries(self) -> dict[str, Any]:
        return {
            table_file(name, self.fmt): {
                "rows": t.rows,
                ("parts" if self.fmt == "parquet" else "bytes"): t.size,
                "sha256": t.sha256,
            }
            for name, t in self.tables.items()
        }

    def _drop_old_checkpoints(self) -> None:
        """Remove the checkpoint files the manifest no longer names."""
        keep = None if self.checkpoint is None else self.folder.file(self.checkpoint["file"])
        for p in self.folder.file(CHECKPOINT_DIR).glob("state-*.npz"):
            if p != keep:
                p.unlink(missing_ok=True)
                if p in self.folder.written:
                    self.folder.written.remove(p)

    # ------------------------------------------------------------------ the end
    def finish(
        self, result, *, animation: bool, frames: int, progress=None, figures: bool = True
    ) -> list:
        """Append the states after the last stage to the trajectory, write the summary, the
        figures (unless ``figures`` is false) and the animation (``progress(done, total)`` as
        :meth:`~swarmgames.sim.result.RunResult.write_outputs` calls it); a complete run
        drops its checkpoint.

        Ctrl-C, SIGTERM or SIGHUP while the figures are written stops them: the run then
        ends as interrupted (``summary.json`` says so, the manifest too, and ``--resume``
        writes what is missing).
        """
        n = self.start.shape[0]
        try:
            with deferred_interrupts():
                self.tables["trajectory"].append(result.trajectory.iloc[-n:])  # after the last
                for name, frame in (("metrics", result.metrics), ("swarm", result.swarm)):
                    if self.tables[name].rows == 0:  # no stage completed: the columns alone
                        self.tables[name].append(frame.iloc[:0])
                self._close()
            result.write_outputs(self.folder, animation, frames, progress, figures)
        except KeyboardInterrupt:
            result.summary["interrupted"] = True
        # A signal from here on comes once every file is written: the run is what it is.
        with contextlib.suppress(KeyboardInterrupt), deferred_interrupts():
            interrupted = result.interrupted
            if interrupted:  # summary.json says so, whatever stopped the figures
                self.folder.write_json("summary.json", result.summary)
            else:
                shutil.rmtree(self.folder.file(CHECKPOINT_DIR), ignore_errors=True)
                self.folder.written[:] = [
                    p for p in self.folder.written if CHECKPOINT_DIR not in p.parts
                ]
                self.checkpoint_stage, self.checkpoint, self.records = None, None, None
            self._record_outputs()
            self._write_manifest("interrupted" if interrupted else "complete")
        result.folder = self.folder
        result.files = list(self.folder.written)
        return list(self.folder.written)

    def _record_outputs(self) -> None:
        """Enter the summary, the figures and the animation in the manifest's files."""
        root = self.folder.file(MANIFEST).parent
        tables = {self.folder.file(table_file(name, self.fmt)) for name in TABLE_NAMES}
        tables.add(self.folder.file(MANIFEST))
        for p in self.folder.written:
            if p.is_file() and p not in tables and CHECKPOINT_DIR not in p.relative_to(root).parts:
                self.files[p.relative_to(root).as_posix()] = _entry(p)

    def fail(self, exc: BaseException) -> None:
        """Record in the manifest that the run failed (``interrupted`` for a
        ``KeyboardInterrupt``): the completed stages stay. A run that failed before
        completing any stage removes the files it wrote (it leaves no trace)."""
        with deferred_interrupts():
            self._close()
            if self.stages == 0 and self.wall_before == 0.0:
                for p in self.folder.written:
                    if p.is_dir():
                        shutil.rmtree(p, ignore_errors=True)
                    else:
                        p.unlink(missing_ok=True)
                shutil.rmtree(self.folder.file(CHECKPOINT_DIR), ignore_errors=True)
                self.folder.file(MANIFEST).unlink(missing_ok=True)
                self.folder.written.clear()
                return
            if isinstance(exc, KeyboardInterrupt):
                self._write_manifest("interrupted")
                return
            self.manifest["error"] = f"{type(exc).__name__}: {exc}"[:1000]
            self._write_manifest("failed")

    def _close(self) -> None:
        for f in (*self.tables.values(), self.records):
            if f is not None:
                f.close()

    def _write_manifest(self, status: str) -> None:
        resumable = self.checkpoint_stage is not None and status != "complete"
        self.folder.write_json(
            MANIFEST,
            {
                **self.manifest,
                "status": status,
                "stages_completed": self.stages,
                "checkpoint_every": self.every,
                "checkpoint_stage": self.checkpoint_stage,
                "resumable": resumable,
                "not_resumable_because": None
                if resumable or status == "complete"
                else (self.why_not or "no checkpoint was written"),
                "files": self.files,
                "tables": self._table_entries(),
                "records": None
                if self.records is None
                else {"bytes": self.records.size, "sha256": self.records.sha256},
                "checkpoint": self.checkpoint,
            },
        )
        if self.checkpoint is not None:
            self._drop_old_checkpoints()


def _read_records(path: Path, size: int) -> tuple[dict, list[StageRecord]]:
    """The header and the stage records among the first ``size`` bytes of ``path`` (checked
    against the manifest before)."""
    try:
        with open(path, "rb") as fh:
            data = fh.read(size)
        items = [datafile.loads(blob) for blob in datafile.split_frames(data)]
    except OSError as exc:
        raise RunFolderError(f"cannot read {path}: {exc.strerror}") from None
    except ValueError as exc:
        raise RunFolderError(f"cannot read {path}: {exc}") from None
    if (
        not items
        or not isinstance(items[0], dict)
        or items[0].get("format") != FORMAT
        or not all(isinstance(r, StageRecord) for r in items[1:])
    ):
        raise RunFolderError(f"{path} is not a stage journal of this swarmgames")
    return items[0], items[1:]


def read_records(folder, manifest: dict) -> tuple[np.ndarray, list[StageRecord], float]:
    """The start states, the stage records the manifest knows and the control period of the
    run in ``folder`` (a RunFolder), checked against the manifest first.

    Raises
    ------
    RunFolderError
        The records do not match the manifest, or cannot be read.
    """
    root = folder.file(MANIFEST).parent
    entry = manifest.get("records")
    if entry is None:
        raise RunFolderError(f"{root} keeps no stage records (the run is complete)")
    _check(root, RECORDS, entry)
    header, records = _read_records(folder.file(RECORDS), entry["bytes"])
    try:
        return np.asarray(header["start"], dtype=float), records, float(header["period_s"])
    except (KeyError, TypeError, ValueError):
        raise RunFolderError(f"{folder.file(RECORDS)} has no valid header") from None


def read_checkpoint(folder, manifest: dict) -> Checkpoint | None:
    """The checkpoint the manifest of ``folder`` (a RunFolder) names, or None if it names
    none. Its file, the tables and the stage records are checked against the manifest
    before the checkpoint is read.

    Raises
    ------
    RunFolderError
        A file that does not match the manifest, an unreadable checkpoint, or a
        ``config.toml`` changed since it was written.
    """
    entry = manifest.get("checkpoint")
    if entry is None:
        return None
    root = folder.file(MANIFEST).parent
    name = entry.get("file") if isinstance(entry, dict) else None
    if not isinstance(name, str) or not name.startswith(f"{CHECKPOINT_DIR}/state-"):
        raise RunFolderError(f"{root / MANIFEST} names no valid checkpoint")
    _check(root, name, entry)
    fmt = manifest.get("tables_format")
    tables = entry.get("tables")
    if not isinstance(tables, dict) or set(tables) != {table_file(t, fmt) for t in TABLE_NAMES}:
        raise RunFolderError(f"{root / MANIFEST} names no valid checkpoint")
    for table, known in tables.items():
        _check(root, table, known, fmt)
    _check(root, RECORDS, entry.get("records"))
    path = folder.file(name)
    try:
        point = datafile.loads(path.read_bytes())
        point = Checkpoint(**{k: v for k, v in point.items() if k != "format"})
    except (OSError, ValueError, TypeError, AttributeError) as exc:
        raise RunFolderError(f"cannot read {path}: {str(exc)[:200]}") from None
    if not isinstance(point.loop, LoopState) or point.sizes.get(RECORDS) != entry["records"].get(
        "bytes"
    ):
        raise RunFolderError(f"{path} is not a checkpoint of this swarmgames")
    for table in TABLE_NAMES:
        known = tables[table_file(table, fmt)]
        if point.sizes.get(table) != known.get("parts", known.get("bytes")):
            raise RunFolderError(f"{path} does not match the manifest of its run folder")
    try:
        text = folder.file("config.toml").read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise RunFolderError(f"cannot read {folder.file('config.toml')}: {exc}") from None
    if text != point.config:
        raise RunFolderError(
            f"{folder.file('config.toml')} changed after the run stopped; a run resumes only "
            "with the configuration it started with"
        )
    return point
