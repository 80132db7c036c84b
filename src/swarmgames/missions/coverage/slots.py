"""Rows that may share their computation: equal ids *and* equal values.

The coverage unary of a variable depends on its state, next states and valid actions; the
games of a stage hold the same robot many times. :func:`shared_rows` gives every row a slot,
equal for rows that hold the same robot in the same state, in time linear in the rows (a
direct-address table over the ids and one comparison per row, compiled with Numba).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["shared_rows"]


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
