"""The distinct rows of a stage: every (robot, state) its local games hold, once.

A stage's local games hold the same robot many times: in its own game and in each of its
neighbours', with the state a message reported, or as a virtual mean (eq. 3). A row is one
such variable: its id ``2 * member + is_virtual``, its state, its next states and its valid
actions. :class:`StageRows` numbers the distinct rows of a stage once, across the batches
the stage splits its games into, and every batch refers to them by index
(:attr:`~swarmgames.game.batch.LocalGameBatch.rows`, in the spirit of jraph's indexed
graphs): potentials compute what depends on a row alone once per row and gather it, games
that hold the same rows are equal (:mod:`~swarmgames.game.equal`), and what is kept from one
batch or stage to the next (:mod:`~swarmgames.game.kept`) is keyed by rows.

:func:`shared_rows` gives the rows of one array their slots in time linear in the rows (a
direct-address table over the ids and one comparison per row, compiled with Numba).

References
----------
.. [1] P. Battaglia et al., "Relational inductive biases, deep learning, and graph
   networks", arXiv 1806.01261 (2018): graphs as arrays of nodes and edges referred to by
   index, the layout of jraph's ``GraphsTuple``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numba import njit

from swarmgames.game.kept import RowTables

__all__ = ["StageRows", "row_ids", "shared_rows"]


@njit(cache=True, nogil=True)
def _id_slots(ids, lo, span):
    """``(slot, first)`` of ``np.unique(ids, return_index=True, return_inverse=True)``
    (slots in increasing id order, the first row of each) for ids in ``lo .. lo + span - 1``,
    by a direct-address table."""
    first_of = np.full(span, -1, np.int64)
    for i in range(ids.size):
        j = ids[i] - lo
        if first_of[j] < 0:
            first_of[j] = i
    rank = np.empty(span, np.int64)
    n = 0
    for j in range(span):
        if first_of[j] >= 0:
            rank[j] = n
            n += 1
    first = np.empty(n, np.int64)
    for j in range(span):
        if first_of[j] >= 0:
            first[rank[j]] = first_of[j]
    slot = np.empty(ids.size, np.int64)
    for i in range(ids.size):
        slot[i] = rank[ids[i] - lo]
    return slot, first


@njit(cache=True, nogil=True)
def _keep_equal(values, ref, same):
    """``same[i] &= (values[i] == values[ref[i]]).all()`` for the rows of ``values`` (R, m)
    (numpy's ``==``: NaN differs from itself, so a row holding one differs even from its
    own id's first row, itself; -0 equals 0)."""
    for i in range(values.shape[0]):
        r = ref[i]
        if not same[i]:
            continue
        for j in range(values.shape[1]):
            if values[i, j] != values[r, j]:
                same[i] = False
                break


def shared_rows(ids: np.ndarray, *values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows that may share their computation: equal ``ids`` *and* equal ``values``.

    Ids such as ``2 * member + is_virtual`` say which rows should hold the same state, but a
    robot's beliefs about a neighbour may differ between games (routed delivery), so a row
    whose values differ from its id's first row gets a slot of its own.

    Parameters
    ----------
    ids : ndarray of int, shape (R,)
    *values : ndarray, shape (R, ...)
        What must be equal (states, next states, valid actions).

    Returns
    -------
    slot : ndarray of int64, shape (R,)
        Rows with equal slots have equal ids and values; slots are 0 .. U - 1: first the
        distinct ids in increasing order, then the rows that differ from their id's first.
    first : ndarray of int64, shape (U,)
        A row of every slot (the first row of each id, then those rows).

    Examples
    --------
    >>> slot, first = shared_rows(np.array([7, 7, 7]), np.array([[1.0], [1.0], [2.0]]))
    >>> slot.tolist(), first.tolist()
    ([0, 0, 1], [0, 2])
    """
    ids = np.ascontiguousarray(ids, dtype=np.int64).reshape(-1)
    if ids.size == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    lo, hi = int(ids.min()), int(ids.max())
    if hi - lo < 4 * ids.size + 1024:
        slot, first = _id_slots(ids, lo, hi - lo + 1)
    else:  # sparse ids: a sort
        _, first, slot = np.unique(ids, return_index=True, return_inverse=True)
        slot = slot.reshape(-1).astype(np.int64)
    ref = first[slot]
    same = np.ones(slot.size, dtype=bool)
    for v in values:
        v = np.ascontiguousarray(v).reshape(slot.size, -1)
        _keep_equal(v.view(np.uint8) if v.dtype == np.bool_ else v, ref, same)
    own = np.flatnonzero(~same)
    slot[own] = first.size + np.arange(own.size)
    return slot, np.concatenate([first, own]).astype(np.int64)


def row_ids(members: np.ndarray, is_virtual: np.ndarray) -> np.ndarray:
    """``2 * member + is_virtual``, (B, K) int64: which variables of a batch should hold the
    same state (a robot, or its virtual mean)."""
    return 2 * np.asarray(members, dtype=np.int64) + np.asarray(is_virtual, dtype=bool)


@dataclass(eq=False)
class StageRows:
    """The distinct rows of one stage's local games, numbered across its batches.

    Rows are equal when their ids, states, next states and valid actions are equal (as
    :func:`shared_rows` compares them); equal rows of any two batches of the stage get the
    same index. A stage makes one (the :func:`~swarmgames.game.stage.solve` pipeline) and
    gives it to every batch it builds; a batch built alone gets one of its own.

    Parameters
    ----------
    kept : RowTables or None, default None
        The bounded tables of per-row values kept across the stages of a run
        (:class:`~swarmgames.game.kept.RowTables`); None: nothing is kept beyond the stage.

    Attributes
    ----------
    n_rows : int
        Distinct rows numbered so far.
    """

    kept: RowTables | None = None
    n_rows: int = field(default=0, init=False)
    _index: dict = field(default_factory=dict, init=False, repr=False)
    _carried: dict = field(default_factory=dict, init=False, repr=False)

    def index(self, ids, mask, states, next_states, action_mask) -> np.ndarray:
        """The row of every valid variable of a batch, (B, K) int64, -1 at padding.

        Parameters
        ----------
        ids : ndarray of int, shape (B, K)
            :func:`row_ids` of the variables.
        mask : ndarray of bool, shape (B, K)
        states : ndarray, shape (B, K, D)
        next_states : ndarray, shape (B, K, A, D)
        action_mask : ndarray of bool, shape (B, K, A)
        """
        mask = np.asarray(mask, dtype=bool)
        out = np.full(mask.shape, -1, dtype=np.int64)
        rb, rk = np.nonzero(mask)
        if rb.size == 0:
            return out
        ids = np.asarray(ids, dtype=np.int64)[rb, rk]
        values = (
            np.asarray(states, dtype=float)[rb, rk],
            np.asarray(next_states, dtype=float)[rb, rk].reshape(rb.size, -1),
            np.asarray(action_mask, dtype=bool)[rb, rk],
        )
        slot, first = shared_rows(ids, *values)
        # One key of bytes per distinct row of the batch: its id and values. A row holding
        # NaN is equal to no other (shared_rows gave it a slot of its own) and is not keyed.
        keys = np.concatenate(
            [ids[first, None].view(np.uint8)]
            + [np.ascontiguousarray(v[first]).view(np.uint8) for v in values],
            axis=1,
        )
        own = np.isnan(values[0][first]).any(axis=1) | np.isnan(values[1][first]).any(axis=1)
        stage_row = np.empty(first.size, dtype=np.int64)
        index = self._index
        for u in range(first.size):
            if own[u]:
                stage_row[u] = self.n_rows
                self.n_rows += 1
                continue
            key = keys[u].tobytes()
            r = index.get(key)
            if r is None:
                r = index[key] = self.n_rows
                self.n_rows += 1
            stage_row[u] = r
        out[rb, rk] = stage_row[slot]
        return out

    def carried(self, owner, name: str):
        """What the stage's last batch left under ``(owner, name)`` for the next
        (:meth:`carry`), or None. ``owner`` is whoever computed it (the potentials, compared
        by identity), so that two potentials never read each other's values."""
        return self._carried.get((owner, name))

    def carry(self, owner, name: str, value) -> None:
        """Leave ``value`` under ``(owner, name)`` for the stage's next batch (None:
        nothing)."""
        if value is None:
            self._carried.pop((owner, name), None)
        else:
            self._carried[(owner, name)] = value
