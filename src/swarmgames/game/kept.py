"""Per-row values kept across the batches and stages of a run, in bounded tables.

A value that depends on one row alone (a robot in a state, :mod:`~swarmgames.game.rows`),
such as the coverage mission's signals of a state's actions over its window (A × C float32
values, 15 KB at A = 9 and a window of 421 cells), is the same wherever the row appears: in
the other batches of its stage, and in later stages while the robot stays where it is.
:class:`KeptRows` keeps such values in one table of fixed size, so that a row is computed
once while it stays there; :class:`RowTables` holds a run's tables by name, and the stage
hands it to the potentials through its :class:`~swarmgames.game.rows.StageRows`. The mission
keeps nothing itself.

An entry is found by the row's id (``2 * member + is_virtual``) and used only when its
values are equal to the row's, bit for bit (its state, next states and valid actions), for
the same geometry of what is computed. A row is always computed by the same code from those
values, so the results are the same whether its entry was computed in this call or an
earlier one. Entries are replaced by a clock hand with a second chance: the hand never takes
a row that the current chunk uses, and passes over (and clears) a row found again since the
hand last came by, so the rows that several batches share outlive those a stage used once
(the old states of robots that moved). A table holds at most ``max_elems`` float32 values.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numba import njit

__all__ = ["KeptRows", "RowTables"]


@njit(cache=True, nogil=True)
def _assign(def_ids, def_keys, index, ids, keys, stamp, used, now, hand):
    """The table row of every defining row of a chunk, and whether it must be computed.

    A row whose id's entry holds equal keys is found there; any other takes the first entry
    from the clock hand on that no row of this chunk uses (``stamp == now``) and that was
    not used since the hand last passed it (``used``: the hand clears it and moves on), which
    is then the row of its id. Returns ``(rows, miss, hand)``."""
    n, m = def_keys.shape
    cap = ids.size
    rows = np.empty(n, np.int64)
    miss = np.zeros(n, np.bool_)
    for i in range(n):
        d = def_ids[i]
        r = index[d]
        if r >= 0 and ids[r] == d:
            same = True
            for j in range(m):
                if keys[r, j] != def_keys[i, j]:
                    same = False
                    break
            if same:
                rows[i] = r
                stamp[r] = now
                used[r] = True
                continue
        while stamp[hand] == now or used[hand]:
            used[hand] = False
            hand = (hand + 1) % cap
        r = hand
        hand = (hand + 1) % cap
        old = ids[r]
        if old >= 0 and index[old] == r:
            index[old] = -1
        ids[r] = d
        keys[r] = def_keys[i]
        stamp[r] = now
        index[d] = r
        rows[i] = r
        miss[i] = True
    return rows, miss, hand


@dataclass(eq=False)
class KeptRows:
    """A bounded table of per-row float32 blocks kept across calls.

    Parameters
    ----------
    max_elems : int, default 96_000_000
        Upper bound on the table's float32 values (384 MiB); the table holds at least one
        chunk's rows whatever the bound.

    Attributes
    ----------
    table : ndarray of float32, shape (entries, A, C)
        Every entry's block (for the coverage kernel, the signals of a state's A actions
        over its C window cells), read and written at the entries :meth:`assign` gives.
    computed, found : int
        Rows computed into the table, and found there already, since the table was made
        (what the table saved).
    """

    max_elems: int = 96_000_000
    table: np.ndarray = field(default=None, init=False, repr=False)
    _buffer: np.ndarray = field(default=None, init=False, repr=False)
    computed: int = field(default=0, init=False)
    found: int = field(default=0, init=False)
    _geometry: tuple | None = field(default=None, init=False, repr=False)
    _ids: np.ndarray = field(default=None, init=False, repr=False)
    _keys: np.ndarray = field(default=None, init=False, repr=False)
    _stamp: np.ndarray = field(default=None, init=False, repr=False)
    _used: np.ndarray = field(default=None, init=False, repr=False)
    _index: np.ndarray = field(default=None, init=False, repr=False)
    _now: int = field(default=0, init=False, repr=False)
    _hand: int = field(default=0, init=False, repr=False)

    def __post_init__(self) -> None:
        if isinstance(self.max_elems, bool) or int(self.max_elems) != self.max_elems:
            raise ValueError(f"max_elems must be an integer (got {self.max_elems!r})")
        if self.max_elems < 1:
            raise ValueError(f"max_elems must be >= 1 (got {self.max_elems})")

    def capacity(self, n_actions: int, n_cells: int, ids_needed: int) -> int:
        """Entries of the table for blocks of ``n_actions`` × ``n_cells`` values and ids below
        ``ids_needed``: as many as ``max_elems`` allow, at most two per id (at least 1)."""
        per_row = max(1, int(n_actions) * int(n_cells))
        return max(1, min(int(self.max_elems) // per_row, 2 * int(ids_needed)))

    def prepare(self, geometry: tuple, n_actions: int, n_cells: int, rows: int, ids_needed: int,
                key_width: int) -> None:  # fmt: skip
        """Make the table ready for a call: ``geometry`` (any hashable description of what a
        block is computed from besides the row; a new one empties the table), at least
        ``rows`` entries (one chunk's rows), ids below ``ids_needed`` and keys of
        ``key_width`` values."""
        cap = max(int(rows), self.capacity(n_actions, n_cells, ids_needed))
        shape = (cap, n_actions, n_cells)
        size = cap * n_actions * n_cells
        if geometry != self._geometry or self.table is None or self.table.shape[0] < rows:
            self._geometry = geometry
            if self._buffer is None or self._buffer.size < size:
                # Touched once here, not page by page as the clock hand first reaches each
                # row (a fresh page costs about 10 µs on a virtual machine): the first call
                # pays it. A new geometry reuses the buffer: games decided one at a time
                # whose windows differ would otherwise each fill a table of up to 4 N rows.
                self._buffer = np.empty(size, dtype=np.float32)
                self._buffer.fill(0.0)
            self.table = self._buffer[:size].reshape(shape)
            self._ids = np.full(cap, -1, dtype=np.int64)
            self._keys = np.empty((cap, key_width), dtype=np.float64)
            self._stamp = np.full(cap, -1, dtype=np.int64)
            self._used = np.zeros(cap, dtype=np.bool_)
            self._index = np.full(0, -1, dtype=np.int64)
            self._hand = 0
        if self._index.size < ids_needed:
            grown = np.full(max(int(ids_needed), 2 * self._index.size), -1, dtype=np.int64)
            grown[: self._index.size] = self._index
            self._index = grown

    def assign(self, ids: np.ndarray, keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(entries, miss)`` for one chunk's distinct rows (``ids`` (U,), ``keys`` (U, m)
        float64: the values an entry must match): the table entry of each, and which must
        be computed into it."""
        self._now += 1
        rows, miss, self._hand = _assign(
            np.ascontiguousarray(ids, dtype=np.int64),
            np.ascontiguousarray(keys, dtype=np.float64),
            self._index,
            self._ids,
            self._keys,
            self._stamp,
            self._used,
            self._now,
            self._hand,
        )
        n_miss = int(miss.sum())
        self.computed += n_miss
        self.found += int(miss.size) - n_miss
        return rows, miss


@dataclass(eq=False)
class RowTables:
    """The tables of per-row values one run keeps across its stages, by name.

    A controller holds one for its run and puts it in every
    :class:`~swarmgames.game.problem.StageProblem`; the stage hands it to the potentials
    (:attr:`~swarmgames.game.rows.StageRows.kept`). What is kept changes no result.
    """

    _tables: dict = field(default_factory=dict, init=False, repr=False)

    def table(self, owner, name: str, max_elems: int) -> KeptRows:
        """The table ``name`` of ``owner`` (whoever computes its values, the potentials,
        compared by identity), of at most ``max_elems`` float32 values: a new, empty one the
        first time or when the bound changed."""
        key = (owner, name)
        table = self._tables.get(key)
        if table is None or table.max_elems != max_elems:
            table = self._tables[key] = KeptRows(max_elems)
        return table
