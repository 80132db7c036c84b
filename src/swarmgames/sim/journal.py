"""The journal of a run folder: each completed stage kept at once, checkpoints, a manifest.

While a run goes on, its folder holds

* ``config.toml``, written before the first stage;
* the tables ``trajectory``, ``metrics`` and ``swarm`` (CSV, gzip-compressed CSV or Parquet:
  :mod:`swarmgames.sim.tables`), to which every completed stage is appended whole, so that a
  killed run leaves every stage it completed readable;
* ``manifest.json``, rewritten (atomically) after every stage: the run's status, the stages
  completed, the rows and bytes of each table, whether and from where it can be resumed;
* ``checkpoint/stages.pickle``: every stage record, exact (the tables' values and the links of
  the routing tables), appended like the tables; from it the summary, the figures and the
  animation can be rebuilt whatever stopped the run;
* ``checkpoint/state.pickle``: the stage loop's state (:class:`~swarmgames.sim.loop.LoopState`:
  states, random states, the network provider's and the communication model's state), every
  ``sim.checkpoint_every`` stages, with the sizes the tables had then.

At the end come the figures, the animation and ``summary.json``; the manifest then says
``complete`` and ``checkpoint/`` is removed. ``swarmgames run --resume DIR`` cuts the tables
back to the last checkpoint, restores the loop and goes on: the run ends bit for bit as an
uninterrupted run would (wall times aside).

The pickles are for the run folders a user's own runs wrote: loading a pickle can run code,
so resume only folders you trust.
"""

from __future__ import annotations

import io
import json
import pickle
import shutil
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from swarmgames.errors import RunFolderError
from swarmgames.network.provider import SnapshotUnsupported
from swarmgames.sim.loop import LoopState, StageLog, StageRecord
from swarmgames.sim.tables import TABLE_NAMES, choose_format, open_table, remove_stale, table_file

__all__ = [
    "MANIFEST",
    "Checkpoint",
    "RunJournal",
    "read_checkpoint",
    "read_manifest",
    "read_records",
]

MANIFEST = "manifest.json"
CHECKPOINT_DIR = "checkpoint"
RECORDS = f"{CHECKPOINT_DIR}/stages.pickle"
STATE = f"{CHECKPOINT_DIR}/state.pickle"
#: Version of the journal's files; a folder of another version is not resumed.
FORMAT = 1


@dataclass(frozen=True, eq=False)
class Checkpoint:
    """The content of ``checkpoint/state.pickle``.

    Attributes
    ----------
    stage : int
        Stages completed at the checkpoint.
    config : str
        The run's ``config.toml`` text (a resumed run checks it is unchanged).
    loop : LoopState
    sizes : dict of int
        Size of each table (bytes; Parquet: parts) and of ``stages.pickle`` (bytes) at the
        checkpoint.
    rows : dict of int
        Rows of each table at the checkpoint.
    tables : str
        The tables' format.
    wall_s : float
        Wall time of the run until the checkpoint, s.
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
    from pathlib import Path

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
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise RunFolderError(f"cannot read {file}: {exc}") from None
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
        raise RunFolderError(f"{file} is not a manifest of this swarmgames (format {FORMAT})")
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
        folder.write_text("config.toml", text)
        remove_stale(folder, fmt)
        for name in TABLE_NAMES:
            journal.tables[name] = open_table(folder, name, fmt)
        journal.records = folder.append_file(RECORDS)
        header = {"format": FORMAT, "start": journal.start, "period_s": loop.period_s}
        journal.records.append(pickle.dumps(header, protocol=pickle.HIGHEST_PROTOCOL))
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
        self.records.append(pickle.dumps(record, protocol=pickle.HIGHEST_PROTOCOL))
        self.stages += 1
        self.previous = record.after
        if self.why_not is None and self.stages % self.every == 0:
            self._checkpoint(loop, self.wall_before + time.perf_counter() - self.t0)
        self._write_manifest("running")

    def _checkpoint(self, loop, wall_s: float) -> None:
        sizes = {name: f.size for name, f in self.tables.items()}
        sizes[RECORDS] = self.records.size
        point = Checkpoint(
            stage=self.stages,
            config=self.config_text,
            loop=loop.state(),
            sizes=sizes,
            rows={name: t.rows for name, t in self.tables.items()},
            wall_s=float(wall_s),
            tables=self.fmt,
        )
        self.folder.write_bytes(STATE, pickle.dumps(point, protocol=pickle.HIGHEST_PROTOCOL))
        self.checkpoint_stage = self.stages

    # ------------------------------------------------------------------ the end
    def finish(
        self, result, *, animation: bool, frames: int, progress=None, figures: bool = True
    ) -> list:
        """Append the states after the last stage to the trajectory, write the figures (unless
        ``figures`` is false), the animation and the summary (``progress(done, total)`` as
        :meth:`~swarmgames.sim.result.RunResult.write_outputs` calls it); a complete run
        drops its checkpoint."""
        interrupted = result.interrupted
        n = self.start.shape[0]
        self.tables["trajectory"].append(result.trajectory.iloc[-n:])  # after the last stage
        for name, frame in (("metrics", result.metrics), ("swarm", result.swarm)):
            if self.tables[name].rows == 0:  # no stage completed: the columns alone
                self.tables[name].append(frame.iloc[:0])
        self._close()
        written = result.write_outputs(self.folder, animation, frames, progress, figures)
        if not interrupted:
            shutil.rmtree(self.folder.file(CHECKPOINT_DIR), ignore_errors=True)
            self.folder.written[:] = [
                p for p in self.folder.written if CHECKPOINT_DIR not in p.parts
            ]
            self.checkpoint_stage = None
        self._write_manifest("interrupted" if interrupted else "complete")
        result.folder = self.folder
        result.files = list(self.folder.written)
        return written

    def fail(self, exc: BaseException) -> None:
        """Record in the manifest that the run failed: the completed stages stay. A run that
        failed before completing any stage removes the files it wrote (it leaves no trace)."""
        self._close()
        if self.stages == 0 and self.wall_before == 0.0:
            for p in self.folder.written:
                p.unlink(missing_ok=True)
            shutil.rmtree(self.folder.file(CHECKPOINT_DIR), ignore_errors=True)
            self.folder.written.clear()
            return
        self.manifest["error"] = f"{type(exc).__name__}: {exc}"
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
                "tables": {
                    table_file(name, self.fmt): {
                        "rows": t.rows,
                        ("parts" if self.fmt == "parquet" else "bytes"): t.size,
                    }
                    for name, t in self.tables.items()
                },
            },
        )


def _read_records(path, size: int | None, strict: bool = True) -> tuple[dict, list[StageRecord]]:
    """The header and the stage records among the first ``size`` bytes of ``path`` (all of
    it when ``size`` is None). ``strict=False``: stop at a damaged record instead of
    raising (a file cut short by a system crash)."""
    try:
        with open(path, "rb") as fh:
            data = fh.read() if size is None else fh.read(size)
    except OSError as exc:
        raise RunFolderError(f"cannot read {path}: {exc.strerror}") from None
    buf = io.BytesIO(data)
    items = []
    while buf.tell() < len(data):
        try:
            items.append(pickle.load(buf))
        except Exception as exc:  # a damaged file: name it
            if strict or not items:
                raise RunFolderError(f"cannot read {path}: {type(exc).__name__}") from None
            break
    if not items or not isinstance(items[0], dict) or items[0].get("format") != FORMAT:
        raise RunFolderError(f"{path} is not a stage journal of this swarmgames")
    return items[0], items[1:]


def read_records(folder) -> tuple[np.ndarray, list[StageRecord], float]:
    """The start states, every stage record that survived and the control period of the run
    in ``folder`` (a RunFolder)."""
    header, records = _read_records(folder.file(RECORDS), None, strict=False)
    return np.asarray(header["start"], dtype=float), records, float(header["period_s"])


def read_checkpoint(folder, manifest: dict) -> Checkpoint | None:
    """The checkpoint of the run in ``folder`` (a RunFolder), or None if it has none.

    Raises
    ------
    RunFolderError
        The checkpoint is unreadable, or ``config.toml`` changed since it was written.
    """
    path = folder.file(STATE)
    if not path.is_file():
        return None
    try:
        point = pickle.loads(path.read_bytes())
    except Exception as exc:
        raise RunFolderError(f"cannot read {path}: {type(exc).__name__}: {exc}") from None
    if not isinstance(point, Checkpoint):
        raise RunFolderError(f"{path} is not a checkpoint of this swarmgames")
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
