"""The 2-hop set of every node: the tuples a HELLO round adds, and the strict 2-hop
neighbourhood read from them, each in one compiled pass over the swarm's tuples.

A HELLO from a symmetric neighbour ``j`` of ``r`` replaces the 2-hop tuples ``(r, j, x)``
that ``r`` holds with one for every symmetric neighbour ``x != r`` that it lists (RFC 3626
section 8.2.1). :func:`round_tuples` writes a round's new tuples, sorted, straight from the
(receiver, sender) pairs and the senders' lists: no intermediate arrays of the N K² keys of a
dense round, and no sort of them.

RFC 3626 uses a node's 2-hop tuples ``(r, j, x)`` only where ``j`` is a symmetric neighbour of
``r`` and ``x`` is neither ``r`` itself nor one of its symmetric neighbours: the strict 2-hop
neighbourhood of the MPR computation (section 8.3.1) and of the routes of section 10 (step 2).
In a dense swarm every node hears every other, its 2-hop table holds N K² tuples (27 M for
300 UAVs within range) and none of them is strict. Filtering them with two sorted look-ups per
tuple (the relay among the links, the target among them) and a division per tuple cost about
0.2 s each time; :func:`strict_two_hop` walks the sorted table once, owner by owner, with the
owner's symmetric neighbours flagged in an array of N entries, so each tuple costs a few
comparisons.

References
----------
.. [1] RFC 3626 sections 8.3.1 (the strict 2-hop neighbourhood N2) and 10 (step 2).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["round_tuples", "strict_two_hop"]


def strict_two_hop(
    keys: np.ndarray, expiry: np.ndarray, clock: np.ndarray, sym_keys: np.ndarray, n: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The strict 2-hop tuples of a 2-hop table, valid at each owner's clock.

    Parameters
    ----------
    keys : ndarray of int64, shape (T,)
        The 2-hop table's keys ``(r N + j) N + x``, ascending.
    expiry : ndarray of float64, shape (T,)
        Their expiry times; a tuple is valid while ``expiry > clock[r]``.
    clock : ndarray of float64, shape (N,)
        Every owner's time of evaluation.
    sym_keys : ndarray of int64
        The valid symmetric links ``r N + j``, ascending and unique.
    n : int
        N, the number of nodes.

    Returns
    -------
    owner, neigh, two_hop : ndarray of int32
        ``(r, j, x)`` of every valid tuple with ``j`` a symmetric neighbour of ``r``,
        ``x != r`` and ``x`` not a symmetric neighbour of ``r``, in the table's order: the
        triples ``(key // N², key // N % N, key % N)`` filtered by those three conditions.

    Examples
    --------
    Node 0 has symmetric neighbours 1 and 2; through 1 it hears of 2 (a neighbour already),
    of 0 (itself) and of 3:

    >>> n = 4
    >>> keys = np.array([(0 * n + 1) * n + x for x in (0, 2, 3)])
    >>> strict_two_hop(keys, np.full(3, 9.0), np.zeros(n), np.array([1, 2]), n)
    (array([0], dtype=int32), array([1], dtype=int32), array([3], dtype=int32))
    """
    keys = np.ascontiguousarray(keys, dtype=np.int64)
    args = (
        keys,
        np.ascontiguousarray(expiry, dtype=np.float64),
        np.ascontiguousarray(clock, dtype=np.float64),
        np.ascontiguousarray(sym_keys, dtype=np.int64),
        np.int64(n),
    )
    # One pass when the strict tuples fit a buffer of a few MB (none in a clique; about one
    # per tuple at constant density), a second one of the counted size otherwise.
    out = np.empty((3, min(keys.size, STRICT_BUFFER)), dtype=np.int32)
    m = _strict(*args, out)
    if m > out.shape[1]:
        out = np.empty((3, m), dtype=np.int32)
        _strict(*args, out)
    return out[0, :m], out[1, :m], out[2, :m]


STRICT_BUFFER = 1 << 20
"""Strict tuples that :func:`strict_two_hop` writes in its first pass (12 MiB); a table that
holds more is walked again into an array of the counted size."""


@njit(cache=True, nogil=True)
def _strict(keys, expiry, clock, sym, n, out):
    """The strict tuples into ``out`` (3, C) as far as it has room, all of them counted;
    returns their number M (``out[:, :M]`` holds them all when M <= C). The sorted keys come
    in runs of one owner, and within it of one relay: a division per run, and the owner's
    neighbours flagged once per owner."""
    room = out.shape[1]
    nn = n * n
    flags = np.zeros(n, np.bool_)
    p = 0  # the first link of the current owner in sym
    a0, a1, b0, b1 = np.int64(1), np.int64(0), np.int64(1), np.int64(0)
    a = b = np.int64(0)
    c = 0.0
    relay_ok = False
    m = 0
    for i in range(keys.size):
        k = keys[i]
        if k < b0 or k >= b1:
            if k < a0 or k >= a1:
                # A new owner: unflag the last one's neighbours, flag this one's.
                q = p
                while q < sym.size and sym[q] < (a + 1) * n:
                    flags[sym[q] - a * n] = False
                    q += 1
                a = k // nn
                a0 = a * nn
                a1 = a0 + nn
                c = clock[a]
                lo = a * n
                while p < sym.size and sym[p] < lo:
                    p += 1
                q = p
                while q < sym.size and sym[q] < lo + n:
                    flags[sym[q] - lo] = True
                    q += 1
            b = (k - a0) // n
            b0 = a0 + b * n
            b1 = b0 + n
            relay_ok = flags[b]
        if not relay_ok:
            continue
        x = k - b0
        if x == a or flags[x] or not expiry[i] > c:  # the expiry last: rarely read in a clique
            continue
        if m < room:
            out[0, m] = a
            out[1, m] = b
            out[2, m] = x
        m += 1
    return m


def round_tuples(
    receivers: np.ndarray,
    senders: np.ndarray,
    listed: np.ndarray,
    ptr: np.ndarray,
    expiry_of: np.ndarray,
    n: int,
) -> tuple[np.ndarray, np.ndarray]:
    """The 2-hop tuples that a HELLO round gives its receivers, sorted by key.

    Parameters
    ----------
    receivers, senders : ndarray of int64, shape (P,)
        The round's (receiver ``r``, symmetric neighbour ``j``) pairs, unique.
    listed : ndarray of int64
        The symmetric neighbours that every sender's HELLO lists, as sorted keys
        ``j N + x``; sender ``j``'s are ``listed[ptr[j]:ptr[j + 1]]``.
    ptr : ndarray of int64, shape (N + 1,)
    expiry_of : ndarray of float64, shape (N,)
        The expiry of the tuples each sender's HELLO gives.
    n : int
        N, the number of nodes.

    Returns
    -------
    keys : ndarray of int64
        ``(r N + j) N + x`` for every pair and every ``x != r`` that ``j`` lists, ascending
        (unique: the pairs are).
    expiry : ndarray of float64
        ``expiry_of[j]`` of each.

    Examples
    --------
    Node 1 lists 0 and 2; node 0 hears it and learns of 2 only:

    >>> keys, expiry = round_tuples(np.array([0]), np.array([1]), np.array([3, 5]),
    ...                             np.array([0, 0, 2, 2]), np.array([0.0, 9.0, 0.0]), 3)
    >>> keys.tolist(), expiry.tolist()
    ([5], [9.0])
    """
    order = np.argsort(np.asarray(receivers, np.int64) * n + senders, kind="stable")
    args = (
        np.ascontiguousarray(receivers, dtype=np.int64)[order],
        np.ascontiguousarray(senders, dtype=np.int64)[order],
        np.ascontiguousarray(listed, dtype=np.int64),
        np.ascontiguousarray(ptr, dtype=np.int64),
        np.ascontiguousarray(expiry_of, dtype=np.float64),
        np.int64(n),
    )
    m = _round(*args, np.empty(0, np.int64), np.empty(0))
    keys, expiry = np.empty(m, np.int64), np.empty(m)
    _round(*args, keys, expiry)
    return keys, expiry


@njit(cache=True, nogil=True)
def _round(rs, js, listed, ptr, expiry_of, n, keys, expiry):
    """The tuples of the (r, j) pairs, in their order, into ``keys`` and ``expiry`` when
    they have room, else counted only; returns their number."""
    write = keys.size > 0
    m = 0
    for p in range(rs.size):
        r, j = rs[p], js[p]
        base = (r * n + j) * n
        e = expiry_of[j]
        for q in range(ptr[j], ptr[j + 1]):
            x = listed[q] - j * n
            if x == r:
                continue
            if write:
                keys[m] = base + x
                expiry[m] = e
            m += 1
    return m
