"""Recorded routing tables replayed as a neighbourhood provider.

A recording is a folder holding ``positions.csv`` (``t,node,x,y,z``; a node's row holds from
``t`` until its next row), ``hops.csv`` (``t,node,dest,hops``; reachable destinations only,
one block of rows per sample time) and ``meta.json`` (at least ``sample``, the sampling period
in seconds). Either CSV file may be compressed instead, with xz (``hops.csv.xz``) or gzip
(``hops.csv.gz``). A recording of several ns-3 runs of one trace has a leading ``run`` column
in ``hops`` (the ns-3 run number of each row). :class:`RecordedProvider` serves the recorded
tables through the :class:`~swarmgames.network.provider.NeighbourhoodProvider` interface, so
that a recorded ns-3 run can be compared with a live backend on a machine without ns-3.

References
----------
.. [1] docs/reference.md section 4, ``ns3/hex_expand``: the recording format.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from swarmgames.errors import InputDataError
from swarmgames.network.provider import NetworkState, check_state
from swarmgames.topology import TopologySnapshot

__all__ = ["RecordedProvider", "Recording", "read_recording"]

_HOPS_COLUMNS = ("t", "node", "dest", "hops")


def _key(t: float) -> int:
    """Sample times as integer microseconds, so that 0.1 + 0.2 and 0.3 are one key."""
    return round(t * 1e6)


class RecordedProvider:
    """Replay recorded routing tables (e.g. an ns-3 run) as a neighbourhood provider.

    Parameters
    ----------
    hops : DataFrame
        Columns ``t, node, dest, hops``: every reachable destination of every node at every
        sample time.
    n_robots : int
        Number of robots of the recording.
    sample_every : float
        Sampling period of the recording, seconds. A sample time without rows means empty
        tables.
    name : str, default "recorded"
        Label of the provider in comparisons.

    Notes
    -----
    ``advance(t, positions)`` ignores ``positions`` (the recording already reflects the trace it
    was made on) and returns the last sample at or before ``t``: the tables at ``k
    sample_every`` with ``k = floor(t / sample_every)``.
    """

    def __init__(
        self, hops: pd.DataFrame, n_robots: int, sample_every: float, *, name: str = "recorded"
    ) -> None:
        missing = [c for c in _HOPS_COLUMNS if c not in hops.columns]
        if missing:
            raise InputDataError(
                f"hops table must have columns {_HOPS_COLUMNS} (missing {missing})"
            )
        if not (math.isfinite(sample_every) and sample_every > 0):
            raise ValueError(f"sample_every must be > 0 (got {sample_every})")
        if n_robots < 1:
            raise ValueError(f"n_robots must be >= 1 (got {n_robots})")
        self.name = name
        self.n_robots = int(n_robots)
        self.sample_every = float(sample_every)
        t = hops["t"].to_numpy(dtype=float)
        cols = {c: hops[c].to_numpy(dtype=np.int64) for c in _HOPS_COLUMNS[1:]}
        bad = (cols["node"] < 0) | (cols["node"] >= n_robots) | (cols["dest"] < 0)
        bad |= (cols["dest"] >= n_robots) | (cols["hops"] < 1) | ~np.isfinite(t)
        if bad.any():
            row = int(np.nonzero(bad)[0][0])
            raise InputDataError(
                f"hops row {row + 2}: node and dest must be in [0, {n_robots}) and hops >= 1 "
                f"(got {hops.iloc[row].to_dict()})"
            )
        keys = np.array([_key(x) for x in t], dtype=np.int64)
        order = np.argsort(keys, kind="stable")
        keys = keys[order]
        bounds = np.flatnonzero(np.diff(keys)) + 1
        starts = np.concatenate([[0], bounds])
        ends = np.concatenate([bounds, [keys.size]])
        self._rows: dict[int, tuple[np.ndarray, ...]] = {
            int(keys[a]): tuple(cols[c][order][a:b] for c in _HOPS_COLUMNS[1:])
            for a, b in zip(starts, ends, strict=True)
        }
        self._time = 0.0

    @property
    def time(self) -> float:
        """Current time, seconds."""
        return self._time

    def reset(self, positions: np.ndarray, start_time: float = 0.0) -> TopologySnapshot:
        """Start the replay at ``start_time``; ``positions`` must have one row per robot."""
        n = np.asarray(positions).shape[0]
        if n != self.n_robots:
            raise ValueError(f"positions must have {self.n_robots} rows (got {n})")
        self._time = float(start_time)
        return self._snapshot()

    def advance(self, to_time: float, positions: np.ndarray) -> TopologySnapshot:
        """Move to ``to_time`` and return the last recorded sample at or before it."""
        if not to_time >= self._time - 1e-9:
            raise ValueError(f"to_time must be >= the current time {self._time:g} (got {to_time})")
        self._time = float(to_time)
        return self._snapshot()

    def state(self) -> NetworkState:
        """The replay's state: its time."""
        return NetworkState(self.name, self.n_robots, self._time)

    def restore(self, state: NetworkState) -> None:
        """Continue the replay from ``state``."""
        check_state(self, state)
        self._time = float(state.time)

    def _snapshot(self) -> TopologySnapshot:
        k = math.floor(self._time / self.sample_every + 1e-6)
        rows = self._rows.get(_key(k * self.sample_every))
        if rows is None:
            empty = np.empty(0, dtype=np.int64)
            rows = (empty, empty, empty)
        node, dest, hops = rows
        return TopologySnapshot(self._time, self.n_robots, node, dest, hops)


@dataclass(frozen=True)
class Recording:
    """A recording folder read into memory.

    Attributes
    ----------
    positions : DataFrame
        ``t, node, x, y, z`` rows of the trace.
    hops : DataFrame
        ``t, node, dest, hops`` rows of the recorded tables.
    meta : dict
        Contents of ``meta.json`` (``sample``: sampling period, s; ``run``: ns-3 run number, or
        ``runs``: the run numbers of a recording of several runs...).
    """

    positions: pd.DataFrame
    hops: pd.DataFrame
    meta: dict[str, Any]

    @property
    def runs(self) -> tuple[int, ...]:
        """ns-3 run numbers held in ``hops``: its ``run`` column, else ``meta["run"]`` (or
        ``()`` where the recording does not say)."""
        if "run" in self.hops.columns:
            return tuple(int(k) for k in np.unique(self.hops["run"].to_numpy()))
        return (int(self.meta["run"]),) if "run" in self.meta else ()

    def run_hops(self, run: int | None = None) -> pd.DataFrame:
        """The ``t, node, dest, hops`` rows of one run (``run`` may be left out when the
        recording holds one run).

        Raises
        ------
        ValueError
            If ``run`` is missing for a recording of several runs, or is not one of them.
        """
        if "run" not in self.hops.columns:
            if run is not None and run not in self.runs:
                raise ValueError(f"run must be one of {list(self.runs)} (got {run})")
            return self.hops
        if run is None or run not in self.runs:
            raise ValueError(f"run must be one of {list(self.runs)} (got {run})")
        rows = self.hops[self.hops["run"].to_numpy() == run]
        return rows.drop(columns="run").reset_index(drop=True)

    @property
    def n_robots(self) -> int:
        """Number of robots."""
        return int(self.positions["node"].max()) + 1

    @property
    def sample_every(self) -> float:
        """Sampling period of ``hops``, seconds."""
        return float(self.meta["sample"])

    def provider(self, name: str = "recorded", run: int | None = None) -> RecordedProvider:
        """The tables of run ``run`` (see :meth:`run_hops`) as a :class:`RecordedProvider`."""
        return RecordedProvider(self.run_hops(run), self.n_robots, self.sample_every, name=name)


#: File names a recording's CSV file may have, in the order they are looked for (pandas
#: decompresses by the suffix).
_SUFFIXES = (".csv", ".csv.xz", ".csv.gz")


def _csv(folder: Path, stem: str) -> Path:
    """The first of ``folder/stem.csv``, ``.csv.xz``, ``.csv.gz`` that exists (else the
    first, for the error message)."""
    found = [folder / f"{stem}{s}" for s in _SUFFIXES if (folder / f"{stem}{s}").is_file()]
    return found[0] if found else folder / f"{stem}.csv"


def read_recording(folder: str | Path) -> Recording:
    """Read ``positions.csv``, ``hops.csv`` (either may be ``.csv.xz`` or ``.csv.gz``) and
    ``meta.json`` from ``folder``.

    Raises
    ------
    InputDataError
        If a file is missing or ``meta.json`` has no ``sample`` period.

    Examples
    --------
    >>> rec = read_recording("tests/data/ns3/fast_20")  # doctest: +SKIP
    >>> rec.runs  # doctest: +SKIP
    (1, 2, 3, 4, 5, 6, 7, 8, 9, 10)
    >>> rec.provider("ns3 run 4", run=4)  # doctest: +SKIP
    """
    folder = Path(folder)
    files = {
        "positions.csv": _csv(folder, "positions"),
        "hops.csv": _csv(folder, "hops"),
        "meta.json": folder / "meta.json",
    }
    for name, path in files.items():
        if not path.is_file():
            raise InputDataError(f"recording {folder} has no {name}")
    meta = json.loads(files["meta.json"].read_text(encoding="utf-8"))
    if "sample" not in meta:
        raise InputDataError(f"{files['meta.json']}: missing 'sample' (sampling period, s)")
    return Recording(
        positions=pd.read_csv(files["positions.csv"]),
        hops=pd.read_csv(files["hops.csv"]),
        meta=meta,
    )
