"""Sparse keyed tables: OLSR's information repositories as sorted arrays of integer keys.

RFC 3626 keeps, per node, sets of tuples (link set, 2-hop set, MPR-selector set, topology set),
each with an expiry time. Here every node's set is stored in one table for the whole swarm: a
tuple is identified by an ``int64`` key that packs its node indices (for example
``owner * N + neighbour``) and its fields are parallel ``float64`` columns. Keys are kept sorted,
so look-ups are ``searchsorted`` and updates are vectorised merges: no per-tuple Python objects.
The two passes a dense swarm repeats over tens of millions of 2-hop tuples, membership in a
flag array and the merge of a HELLO round's new tuples, are compiled loops (Numba), and so is
the test of the tuples' expiry against their owner's clock (one integer division per owner,
not per tuple).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from swarmgames.arrays import sorted_unique

__all__ = [
    "DENSE_LIMIT",
    "KeySet",
    "KeyedTable",
    "first_per_key",
    "live_at",
    "sorted_contains",
]

#: Largest key range (N * N, i.e. N = 3 000 robots) for which dense per-pair arrays are used
#: instead of sorted keys (about 150 MB of working arrays at the limit).
DENSE_LIMIT = 9_000_000

#: Sorted look-ups of at least this many keys walk the table once instead of searching it.
_WALK_MIN = 100_000


class KeyedTable:
    """A set of tuples with unique sorted ``int64`` keys and named ``float64`` columns.

    Parameters
    ----------
    columns : sequence of str
        Column names.

    Notes
    -----
    This is the mutable working store of the OLSR engine; snapshots handed to users are
    immutable copies.
    """

    def __init__(self, columns: tuple[str, ...]) -> None:
        self.keys = np.zeros(0, dtype=np.int64)
        self.cols = {c: np.zeros(0, dtype=float) for c in columns}

    def __len__(self) -> int:
        return int(self.keys.size)

    def find(self, keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions of ``keys`` in the table and a mask of which were found."""
        keys = np.asarray(keys, dtype=np.int64)
        if keys.ndim == 1 and keys.size > _WALK_MIN and bool(np.all(keys[1:] >= keys[:-1])):
            # Many sorted keys (a HELLO round's 2-hop tuples): one walk along the table.
            idx = np.empty(keys.size, dtype=np.int64)
            found = np.empty(keys.size, dtype=bool)
            _walk_positions(self.keys, keys, idx, found)
            return idx, found
        idx = np.searchsorted(self.keys, keys)
        found = idx < self.keys.size
        found[found] = self.keys[idx[found]] == keys[found]
        return idx, found

    def get(self, column: str, keys: np.ndarray, default: float = -np.inf) -> np.ndarray:
        """Values of ``column`` at ``keys`` (``default`` where absent)."""
        idx, found = self.find(keys)
        out = np.full(idx.shape, default, dtype=float)
        out[found] = self.cols[column][idx[found]]
        return out

    def getter(self, column: str, size: int):
        """A function ``keys -> values of column`` (``-inf`` where absent) for many look-ups
        on an unchanging table: a dense array of ``size`` entries while ``size`` is at most
        :data:`DENSE_LIMIT`, :meth:`get` otherwise."""
        if size > DENSE_LIMIT:
            return lambda keys: self.get(column, keys)
        dense = np.full(size, -np.inf)
        dense[self.keys] = self.cols[column]
        return dense.__getitem__

    def upsert(self, keys: np.ndarray, **values: np.ndarray) -> None:
        """Insert or overwrite tuples. ``keys`` must be unique; columns not given keep their
        value (existing tuples) or get ``-inf`` (new tuples)."""
        keys = np.asarray(keys, dtype=np.int64)
        idx, found = self.find(keys)
        for name, v in values.items():
            v = np.broadcast_to(np.asarray(v, dtype=float), keys.shape)
            self.cols[name][idx[found]] = v[found]
        new = ~found
        if not new.any():
            return
        if not found.any() and (keys.size < 2 or bool(np.all(keys[1:] > keys[:-1]))):
            # Sorted keys, all new: merge them in, without sorting the whole table again.
            # Their places in the merged table are idx + their rank (idx is non-decreasing),
            # the same for every column.
            at = idx + np.arange(keys.size)
            self.keys = _merged(self.keys, keys, at)
            for name, col in self.cols.items():
                add = np.broadcast_to(np.asarray(values.get(name, -np.inf), float), keys.shape)
                self.cols[name] = _merged(col, np.ascontiguousarray(add), at)
            return
        all_keys = np.concatenate([self.keys, keys[new]])
        order = np.argsort(all_keys, kind="stable")
        self.keys = all_keys[order]
        for name, col in self.cols.items():
            add = np.full(int(new.sum()), -np.inf)
            if name in values:
                add = np.broadcast_to(np.asarray(values[name], dtype=float), keys.shape)[new]
            self.cols[name] = np.concatenate([col, add])[order]

    def keep(self, mask: np.ndarray) -> None:
        """Keep only the tuples where ``mask`` is true (nothing is copied when it keeps them
        all: a dense swarm's 2-hop table holds tens of millions)."""
        if mask.all():
            return
        self.keys = self.keys[mask]
        for name in self.cols:
            self.cols[name] = self.cols[name][mask]

    def drop_prefixes(self, prefixes: np.ndarray, base: int) -> None:
        """Remove every tuple whose ``key // base`` is in ``prefixes``."""
        if self.keys.size and len(prefixes):
            self.keep(~sorted_contains(sorted_unique(prefixes), self.keys // base))


class KeySet:
    """A growing set of ``int64`` keys in ``[0, size)``: a dense flag array when ``size`` is at
    most ``dense_limit`` (fast membership), sorted keys otherwise (memory ~ number of keys)."""

    def __init__(self, size: int, dense_limit: int | None = None) -> None:
        self.dense = size <= (DENSE_LIMIT if dense_limit is None else dense_limit)
        self._flags = np.zeros(int(size), dtype=bool) if self.dense else None
        self._keys = np.zeros(0, dtype=np.int64)

    def contains(self, keys: np.ndarray) -> np.ndarray:
        """Boolean mask of the ``keys`` in the set."""
        if self.dense:
            return self._flags[keys]
        if self._keys.size == 0:
            return np.zeros(np.shape(keys), dtype=bool)
        idx = np.minimum(np.searchsorted(self._keys, keys), self._keys.size - 1)
        return self._keys[idx] == keys

    def add(self, keys: np.ndarray) -> None:
        """Add ``keys`` to the set."""
        if self.dense:
            self._flags[keys] = True
        else:
            self._keys = np.union1d(self._keys, keys)


def first_per_key(keys: np.ndarray, size: int, order: np.ndarray | None = None) -> np.ndarray:
    """Indices of the first occurrence of each distinct key, "first" in ``order`` (default: the
    array order). Keys lie in ``[0, size)``; a dense claim array is used while ``size`` is at
    most :data:`DENSE_LIMIT`."""
    order = np.arange(keys.size) if order is None else order
    ordered = keys[order]
    if size <= DENSE_LIMIT:
        claim = np.empty(size, dtype=np.int32)
        pos = np.arange(ordered.size, dtype=np.int32)
        claim[ordered[::-1]] = pos[::-1]
        return order[claim[ordered] == pos]
    _, first = np.unique(ordered, return_index=True)
    return order[first]


def sorted_contains(sorted_keys: np.ndarray, query: np.ndarray) -> np.ndarray:
    """Mask of the ``query`` values present in the ascending array ``sorted_keys`` of
    non-negative keys: a lookup in a dense membership array when the keys span at most
    :data:`DENSE_LIMIT` values and the query is not much smaller than that span (a dense
    swarm's 2-hop triples against its links), a binary search per query otherwise (cheaper
    than ``np.isin`` when the sorted side is reused or large). Both give the same mask."""
    query = np.asarray(query)
    if sorted_keys.size == 0:
        return np.zeros(query.shape, dtype=bool)
    top = int(sorted_keys[-1]) + 1
    if top <= DENSE_LIMIT and top <= 16 * query.size:
        member = np.zeros(top, dtype=bool)
        member[sorted_keys] = True
        out = np.empty(query.shape, dtype=bool)
        _flagged(member, np.ascontiguousarray(query, dtype=np.int64).reshape(-1), out.reshape(-1))
        return out
    idx = np.minimum(np.searchsorted(sorted_keys, query), sorted_keys.size - 1)
    return sorted_keys[idx] == query


@njit(cache=True, nogil=True)
def _flagged(flags, query, out):
    """``out[i] = flags[query[i]]``, False outside ``[0, len(flags))``."""
    top = flags.size
    for i in range(query.size):
        q = query[i]
        out[i] = q >= 0 and q < top and flags[q]


@njit(cache=True, nogil=True)
def _merge_into(old, new, at, out):
    j = 0
    i = 0
    for p in range(out.size):
        if j < at.size and at[j] == p:
            out[p] = new[j]
            j += 1
        else:
            out[p] = old[i]
            i += 1


def _merged(old: np.ndarray, new: np.ndarray, at: np.ndarray) -> np.ndarray:
    """``old`` with ``new`` inserted so that ``new[j]`` lands at ``at[j]`` (increasing)."""
    out = np.empty(old.size + new.size, dtype=old.dtype)
    _merge_into(old, new.astype(old.dtype, copy=False), at, out)
    return out


@njit(cache=True, nogil=True)
def _walk_positions(table, query, idx, found):
    """``idx = np.searchsorted(table, query)`` for an increasing ``query``, in one walk, and
    whether each key is in ``table``."""
    i = 0
    n = table.size
    for j in range(query.size):
        q = query[j]
        while i < n and table[i] < q:
            i += 1
        idx[j] = i
        found[j] = i < n and table[i] == q


def live_at(keys: np.ndarray, base: int, expiry: np.ndarray, clock: np.ndarray) -> np.ndarray:
    """``expiry > clock[keys // base]``: the tuples still valid at their owner's clock.

    One integer division per run of keys of the same owner, so a table of sorted keys costs
    a division per owner rather than per tuple (any order gives the same mask)."""
    keys = np.ascontiguousarray(keys, dtype=np.int64)
    out = np.empty(keys.size, dtype=bool)
    _live_at(keys, np.int64(base), np.ascontiguousarray(expiry, dtype=np.float64),
             np.ascontiguousarray(clock, dtype=np.float64), out)  # fmt: skip
    return out


@njit(cache=True, nogil=True)
def _live_at(keys, base, expiry, clock, out):
    lo, hi = np.int64(1), np.int64(0)
    c = 0.0
    for i in range(keys.size):
        k = keys[i]
        if k < lo or k >= hi:
            o = k // base
            lo = o * base
            hi = lo + base
            c = clock[o]
        out[i] = expiry[i] > c
