"""Position traces: read and validate ``t,node,x,y,z`` CSV files into an immutable trace.

A node's row holds from its ``t`` until that node's next row (piecewise-constant positions;
metres and seconds). Every node must have a row at the first time of the trace.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from swarmgames.errors import InputDataError
from swarmgames.section import MAX_COORDINATE_M

__all__ = ["PositionTrace", "read_positions"]

_COLUMNS = ("t", "node", "x", "y", "z")

#: Largest node count of a trace (the schema's swarm.n_robots limit): node ids index arrays.
MAX_TRACE_NODES = 100_000

#: Latest time of a trace, seconds (the schema's sim.duration_s limit, 11.6 days): replay
#: samples and simulates the network over the whole span.
MAX_TRACE_TIME_S = 1e6

#: Largest dense position table (distinct times x nodes x 3 values of 8 bytes: 2 GiB).
MAX_TRACE_VALUES = 2**28


def _cell(value: object) -> object:
    """A cell of the file as the user wrote it (a Python scalar, not a numpy one)."""
    return value.item() if hasattr(value, "item") else value


@dataclass(frozen=True, eq=False)
class PositionTrace:
    """Piecewise-constant positions of ``n_robots`` robots (immutable).

    Parameters
    ----------
    times : ndarray of float, shape (K,)
        Sorted distinct times at which some node moves; ``times[0]`` is the start.
    positions : ndarray of float, shape (K, N, 3)
        ``positions[k]`` holds on ``[times[k], times[k + 1])``.
    """

    times: np.ndarray
    positions: np.ndarray

    @property
    def n_robots(self) -> int:
        """Number of robots N."""
        return int(self.positions.shape[1])

    @property
    def start(self) -> float:
        """First time of the trace, seconds."""
        return float(self.times[0])

    @property
    def end(self) -> float:
        """Last time of the trace, seconds."""
        return float(self.times[-1])

    def at(self, t: float) -> np.ndarray:
        """Positions holding at time ``t`` (shape (N, 3))."""
        k = max(int(np.searchsorted(self.times, t, side="right")) - 1, 0)
        return self.positions[k]

    @classmethod
    def from_frame(cls, frame: pd.DataFrame, source: str = "positions") -> PositionTrace:
        """Validate a ``t,node,x,y,z`` frame (see :func:`read_positions`)."""
        missing = [c for c in _COLUMNS if c not in frame.columns]
        if missing:
            raise InputDataError(
                f"{source}: missing column(s) {', '.join(missing)}; expected columns "
                f"{','.join(_COLUMNS)} (got {','.join(map(str, frame.columns))})"
            )
        if frame.empty:
            raise InputDataError(f"{source}: no rows")
        df = frame[list(_COLUMNS)].reset_index(drop=True)
        # Row numbers as a user sees them in the file: header is line 1.
        line = np.arange(len(df)) + 2
        values = {}
        for col in _COLUMNS:
            v = pd.to_numeric(df[col], errors="coerce").to_numpy(dtype=float)
            bad = ~np.isfinite(v)
            if bad.any():
                k = int(np.flatnonzero(bad)[0])
                raise InputDataError(
                    f"{source}: line {line[k]}, column {col}: must be a finite number "
                    f"(got {_cell(df[col].iloc[k])!r})"
                )
            if col in ("x", "y", "z"):
                far = np.abs(v) > MAX_COORDINATE_M  # squared distances must stay finite
                if far.any():
                    k = int(np.flatnonzero(far)[0])
                    raise InputDataError(
                        f"{source}: line {line[k]}, column {col}: must be within "
                        f"+-{MAX_COORDINATE_M:g} m (got {_cell(df[col].iloc[k])!r})"
                    )
            values[col] = v
        t, node = values["t"], values["node"]
        bad = (node < 0) | (node != np.round(node))
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise InputDataError(
                f"{source}: line {line[k]}, column node: must be an integer >= 0 "
                f"(got {_cell(df['node'].iloc[k])!r})"
            )
        if (t < 0).any():
            k = int(np.flatnonzero(t < 0)[0])
            raise InputDataError(f"{source}: line {line[k]}, column t: must be >= 0 (got {t[k]})")
        if (t > MAX_TRACE_TIME_S).any():
            k = int(np.flatnonzero(t > MAX_TRACE_TIME_S)[0])
            raise InputDataError(
                f"{source}: line {line[k]}, column t: must be <= {MAX_TRACE_TIME_S:g} s, the "
                f"longest span the network layer simulates (got {_cell(df['t'].iloc[k])!r})"
            )
        if (node >= MAX_TRACE_NODES).any():
            k = int(np.flatnonzero(node >= MAX_TRACE_NODES)[0])
            raise InputDataError(
                f"{source}: line {line[k]}, column node: must be < {MAX_TRACE_NODES}, the most "
                f"robots a swarm may have (got {_cell(df['node'].iloc[k])!r})"
            )
        node = node.astype(np.int64)
        # Gaps from the distinct ids (at most one per row), not from an array as long as the
        # largest id.
        ids = np.unique(node)
        n = int(ids[-1]) + 1
        if ids.size != n:
            absent = int(np.flatnonzero(ids != np.arange(ids.size))[0])
            raise InputDataError(
                f"{source}: nodes must be numbered 0..{n - 1} without gaps "
                f"(node {absent} has no row)"
            )
        # Per node, times must strictly increase in file order.
        order = np.lexsort((np.arange(node.size), node))
        same = node[order][1:] == node[order][:-1]
        dt = np.diff(t[order])
        dup = same & (dt == 0)
        if dup.any():
            k = int(order[1:][np.flatnonzero(dup)[0]])
            raise InputDataError(
                f"{source}: line {line[k]}: duplicate row for node {node[k]} at t = {t[k]}"
            )
        dec = same & (dt < 0)
        if dec.any():
            k = int(order[1:][np.flatnonzero(dec)[0]])
            raise InputDataError(
                f"{source}: line {line[k]}, column t: times of node {node[k]} must increase "
                f"(got {t[k]} after {t[order][np.flatnonzero(dec)[0]]})"
            )
        t0 = float(t.min())
        first = np.full(n, np.inf)
        np.minimum.at(first, node, t)
        late = np.flatnonzero(first > t0)
        if late.size:
            raise InputDataError(
                f"{source}: node {int(late[0])} has no row at the start time t = {t0} "
                f"(its first row is at t = {first[late[0]]})"
            )
        times = np.unique(t)
        if times.size * n * 3 > MAX_TRACE_VALUES:
            raise InputDataError(
                f"{source}: {times.size} distinct times x {n} nodes would hold "
                f"{times.size * n * 3 * 8 / 2**30:.1f} GiB of positions (at most "
                f"{MAX_TRACE_VALUES * 8 / 2**30:g} GiB); give the nodes common sample times"
            )
        xyz = np.c_[values["x"], values["y"], values["z"]]
        # Fill forward: position of every node at every event time.
        k_of_row = np.searchsorted(times, t)
        pos = np.full((times.size, n, 3), np.nan)
        pos[k_of_row, node] = xyz
        filled = pd.DataFrame(pos.reshape(times.size, n * 3)).ffill().to_numpy()
        pos = filled.reshape(times.size, n, 3)
        times.setflags(write=False)
        pos.setflags(write=False)
        return cls(times, pos)


def read_positions(path: str | Path) -> PositionTrace:
    """Read a ``t,node,x,y,z`` positions CSV.

    Raises
    ------
    InputDataError
        If the file is missing, a folder, unreadable, empty or not UTF-8, a column is missing,
        a value is NaN / infinite / not a number, a time is negative or after
        :data:`MAX_TRACE_TIME_S`, a node id is not below
        :data:`MAX_TRACE_NODES`, a node has duplicate rows or decreasing times, nodes are not
        numbered ``0..N-1``, a node has no row at the first time, or the dense positions would
        exceed :data:`MAX_TRACE_VALUES`. The message names the line (header = line 1) and
        column.
    """
    path = Path(path)
    try:
        frame = pd.read_csv(path, skipinitialspace=True)
    except FileNotFoundError:
        raise InputDataError(f"positions file not found: {path}") from None
    except IsADirectoryError:
        raise InputDataError(f"cannot read positions file {path}: it is a folder") from None
    except pd.errors.EmptyDataError:
        raise InputDataError(
            f"{path}: empty file; expected a header {','.join(_COLUMNS)} and rows"
        ) from None
    except UnicodeDecodeError as exc:
        raise InputDataError(
            f"{path}: not UTF-8 text (byte {exc.object[exc.start]:#04x}); CSV traces are UTF-8"
        ) from None
    except pd.errors.ParserError as exc:
        why = " ".join(str(exc).split())  # pandas' message may span lines
        raise InputDataError(f"{path}: not a readable CSV file: {why}") from None
    except OSError as exc:
        why = exc.strerror or type(exc).__name__
        raise InputDataError(f"cannot read positions file {path}: {why}") from None
    return PositionTrace.from_frame(frame, source=str(path))
