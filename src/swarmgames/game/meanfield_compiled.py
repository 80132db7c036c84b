"""Compiled mean-field kernel (Numba): every game of a batch solved to convergence in one call.

The numpy engines of :mod:`swarmgames.game.meanfield` update variable k of *all* games of a
batch with a few numpy calls, so each variable update has a fixed cost (about 5 µs) and the
batch's pairwise table streams from memory once per sweep. This kernel instead takes one game
at a time, runs all its sweeps while its table (at most K² A² values) stays in cache, and
spreads the games over threads (``numba.prange``). Each game is solved by the same code
whatever the batch: the mean-field iteration of the module docstring of
:mod:`swarmgames.game.meanfield`, over its valid variables only.

Arithmetic
----------
For variable k and action x the pair field Σ_{(l,c)} W[k, x, l, c] Q_l(c) runs over the
game's n = K_valid · A entries in one contiguous dot product, which the compiler vectorises
(``fastmath`` reassociation of that sum only). Its rounding therefore depends on n and on the
CPU's vector width, never on the padded width K, the other games or the number of threads: a
game gives bit-identical results solved alone, inside any batch, padded to any width, on any
number of threads. Against the numpy engines it agrees to rounding (about 1e-15 relative in
float64). The softmax and the KL divergence are plain sequential loops; the KL is accumulated
in float64 whatever the table precision.

Wide sums
---------
In float32, the rounding of a long pair field (a dense game: K = 300 and A = 9 give 2 700
terms) makes the marginals dither around the fixed point: the KL between sweeps stays near
4e-6 and 45 % of the games of a contracting 300-UAV swarm ran to ``max_iter`` (200 sweeps)
where float64 tables converge in 28–54. Games of at least :data:`WIDE_SUM_MIN` valid entries
therefore accumulate their pair fields in float64 (the products of float32 values are exact
there) and take the logits and the softmax in float64, keeping Q in float32: they converge
as in float64. The choice depends on the game alone, so results stay independent of the
batch and of the thread count; smaller games and float64 tables sum their pair fields in
their own dtype.

Shared tables
-------------
A game may read its pairwise table in another variable order (``perm``): the sweeps update
its variables in the game's own order (Algorithm 1's, the owner first), but the marginals
are kept, and every pair field summed, in the table's order. Games that hold the same
robots in the same states (a dense swarm, where every game holds every robot) then read one
table, held once, instead of one each; a source that ranks every game's variables
canonically (``PairSource.shared``) makes the results independent of which games share.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, Algorithm 1.
.. [2] S. K. Lam, A. Pitrou and S. Seibert, "Numba: a LLVM-based Python JIT compiler",
   LLVM-HPC 2015.
"""

from __future__ import annotations

import os
import threading
from contextlib import contextmanager

# A stage launches dozens of short parallel regions between numpy steps. OpenMP's default
# wait policy keeps idle workers spinning after each, taking the core the Python thread
# needs next: on the 2-core machine a N = 1 000 stage took 0.9 s on two threads against
# 0.55 s on one. Passive workers sleep (0.53 s on two threads). Read when Numba's OpenMP
# layer starts (the first parallel launch); a value the user set is kept.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import numba
import numpy as np
from numba import njit, prange

from swarmgames.game.meanfield import WIDE_SUM_MIN

__all__ = ["POOL_LOCK", "WIDE_SUM_MIN", "pool", "solve_batch"]


@njit(cache=True, nogil=True, inline="always")
def _softmax_into(z, q, off):
    """``q[off : off + A] = softmax(z)`` (``-inf`` entries give 0); z is overwritten."""
    a = z.shape[0]
    mx = z[0]
    for x in range(1, a):
        if z[x] > mx:
            mx = z[x]
    s = z.dtype.type(0.0)
    for x in range(a):
        e = np.exp(z[x] - mx)
        z[x] = e
        s += e
    for x in range(a):
        q[off + x] = z[x] / s


@njit(cache=True, nogil=True, fastmath={"reassoc", "nsz"})
def _dot(row, q, n):
    """Σ_i row[i] q[i] over the first n entries in the table's precision (vectorised; order
    fixed by n)."""
    s = row.dtype.type(0.0)
    for i in range(n):
        s += row[i] * q[i]
    return s


@njit(cache=True, nogil=True, fastmath={"reassoc", "nsz"})
def _dot_wide(row, q, n):
    """:func:`_dot` accumulated in float64 whatever the table precision (the same as it in
    float64)."""
    s = 0.0
    for i in range(n):
        s += np.float64(row[i]) * np.float64(q[i])
    return s


@njit(cache=True, nogil=True, inline="always")
def _update_into(z, logits, wf, off, q, qd, n, beta, has_pair, wide):
    """One variable's update: ``z`` = β·(Σ W Q) + β·U for each action (the order of the
    numpy engines; without ``has_pair`` the logits alone), summed by :func:`_dot_wide` when
    ``wide`` (``z`` float64) and by :func:`_dot` otherwise (``z`` in the table's dtype), then
    ``q[off : off + A] = softmax(z)``. The sums read Q from ``qd``: ``q`` itself, or when
    ``wide`` its float64 copy, kept equal here (each entry converted once per update, not
    once per action and game step)."""
    for x in range(z.shape[0]):
        if not has_pair:
            z[x] = logits[x]
        elif wide:
            z[x] = _dot_wide(wf[off + x], qd, n) * beta + logits[x]
        else:
            z[x] = _dot(wf[off + x], qd, n) * beta + logits[x]
    _softmax_into(z, q, off)
    if wide:
        for x in range(z.shape[0]):
            qd[off + x] = q[off + x]


@njit(cache=True, nogil=True)
def _solve_games(task, games, logits, w, table, perm, nv, has_pair, beta, delta, max_iter,
                 wide_min, q_out, its, kls):  # fmt: skip
    """Mean-field sweeps of the games ``games[task[0]:task[1]]``, which read one table and
    have the same number of valid variables, each until KL < delta or ``max_iter`` sweeps.

    Per game: logits (K, A), β·U with -inf at invalid actions, in the game's order; the pair
    table w[table[g]] (K, A, K, A) in its own order, where variable k of the game is
    variable ``perm[g, k]`` (the identity: the game's order); the first ``nv`` variables of
    both are the valid ones. The sweeps update the game's variables in the game's order;
    the marginals are kept, and every pair field summed, in the table's. The games advance
    in step, variable by variable, so that the rows of the table that the games read at once
    stay in cache; each game's arithmetic is its own. Writes Q into ``q_out[g]`` (K, A) in
    the game's order, the sweeps into ``its[g]`` and the last KL into ``kls[g]``.
    """
    lo, hi = task[0], task[1]
    n_g = hi - lo
    g0 = games[lo]
    a = logits.shape[2]
    n = nv[g0] * a
    dt = logits.dtype
    q = np.zeros((n_g, n), dt)
    q_old = np.empty((n_g, n), dt)
    wide = n >= wide_min
    qd = np.zeros((n_g, n) if wide else (1, 1), np.float64)
    z = np.empty(a, dt)
    z_wide = np.empty(a, np.float64)
    tw = table[g0] * np.int64(has_pair)  # the dummy table of a batch without pairwise term
    wt = w[tw]
    wf = wt.reshape((wt.shape[0] * wt.shape[1], wt.shape[2] * wt.shape[3]))
    live = np.ones(n_g, np.bool_)
    left = n_g
    for i in range(n_g):
        g = games[lo + i]
        its[g] = 0
        kls[g] = np.inf
        for k in range(nv[g]):  # Q from the unary alone
            off = perm[g, k] * a
            if wide:
                _update_into(z_wide, logits[g, k], wf, off, q[i], qd[i], n, beta, False, True)
            else:
                _update_into(z, logits[g, k], wf, off, q[i], q[i], n, beta, False, False)
    while left > 0:
        for i in range(n_g):
            if live[i]:
                q_old[i] = q[i]
                its[games[lo + i]] += 1
        for k in range(nv[g0]):
            for i in range(n_g):
                if not live[i]:
                    continue
                g = games[lo + i]
                off = perm[g, k] * a
                if wide:
                    _update_into(
                        z_wide, logits[g, k], wf, off, q[i], qd[i], n, beta, has_pair, True
                    )
                else:
                    _update_into(z, logits[g, k], wf, off, q[i], q[i], n, beta, has_pair, False)
        for i in range(n_g):
            if not live[i]:
                continue
            g = games[lo + i]
            kl = 0.0
            for k in range(nv[g]):
                off = perm[g, k] * a
                s = 0.0
                for x in range(a):
                    p = np.float64(q_old[i, off + x])
                    if p > 0.0:
                        s += p * (np.log(p) - np.log(np.float64(q[i, off + x])))
                kl += s
            kls[g] = kl
            if kl < delta or its[g] >= max_iter:
                live[i] = False
                left -= 1
    for i in range(n_g):
        g = games[lo + i]
        for k in range(nv[g]):
            for x in range(a):
                q_out[g, k, x] = q[i, perm[g, k] * a + x]


@njit(cache=True, nogil=True, parallel=True)
def _solve_parallel(tasks, *args):
    for t in prange(tasks.shape[0]):
        _solve_games(tasks[t], *args)


@njit(cache=True, nogil=True)
def _solve_serial(tasks, *args):
    for t in range(tasks.shape[0]):
        _solve_games(tasks[t], *args)


def _tasks(table: np.ndarray, n_valid: np.ndarray, threads: int) -> tuple[np.ndarray, np.ndarray]:
    """The games in task order and the ``[start, end)`` of every task: the games that read
    one table (with as many valid variables), split into at most ``threads`` tasks."""
    b = table.size
    if np.array_equal(table, np.arange(b)):  # a table each: a task each
        games = np.arange(b, dtype=np.int64)
        return games, np.stack([games, games + 1], axis=1)
    order = np.lexsort((n_valid, table))
    key_t, key_v = table[order], n_valid[order]
    cut = np.flatnonzero((np.diff(key_t) != 0) | (np.diff(key_v) != 0)) + 1
    lo = np.concatenate([[0], cut])
    size = np.diff(np.concatenate([lo, [b]]))
    per = -(-size // max(1, threads))
    count = -(-size // per)
    group = np.repeat(np.arange(size.size), count)
    part = np.arange(group.size) - np.repeat(np.cumsum(count) - count, count)
    start = lo[group] + part * per[group]
    end = np.minimum(start + per[group], lo[group] + size[group])
    return order.astype(np.int64), np.stack([start, end], axis=1).astype(np.int64)


PARALLEL_MIN_GAMES = 8
"""Batches with fewer games run on the calling thread (a thread-pool launch costs more),
unless their games are large (:data:`PARALLEL_MIN_ENTRIES`)."""

PARALLEL_MIN_ENTRIES = 1_000_000
"""A batch of at least two games whose pairwise tables hold this many entries in all runs on
the thread pool however few its games: a sweep over them costs far more than the launch
(dense swarms, whose batches hold a few games of hundreds of variables each)."""


def in_parallel(n_games: int, entries_per_game: int) -> bool:
    """Whether a batch of ``n_games`` games of ``entries_per_game`` pairwise entries each
    (K² A²) is spread over the thread pool. Each game runs on one thread either way, so the
    results are the same bit for bit.

    Examples
    --------
    >>> in_parallel(8, 100), in_parallel(3, 100), in_parallel(3, 2700**2), in_parallel(1, 10**9)
    (True, False, True, False)
    """
    if n_games >= PARALLEL_MIN_GAMES:
        return True
    return n_games >= 2 and n_games * entries_per_game >= PARALLEL_MIN_ENTRIES


def solve_batch(
    logits: np.ndarray,
    pair: np.ndarray | None,
    n_valid: np.ndarray,
    beta: float,
    delta: float,
    max_iter: int,
    table: np.ndarray | None = None,
    perm: np.ndarray | None = None,
    wide_min: int = WIDE_SUM_MIN,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Solve B games whose valid variables are a prefix of each row.

    Parameters
    ----------
    logits : ndarray, shape (B, K, A)
        β·U, ``-inf`` at invalid actions (at least one finite entry per valid variable).
    pair : ndarray, shape (B, K, A, K, A) or (R, K, A, K, A), or None
        W of :mod:`swarmgames.game.meanfield`, same dtype as ``logits``: one table per game,
        or R tables that games share (``table``, ``perm``).
    n_valid : ndarray of int, shape (B,)
        Valid variables of each game (variables ``0 .. n_valid - 1``).
    beta, delta, max_iter
        As :func:`~swarmgames.game.meanfield.mean_field` (already validated).
    table : ndarray of int, shape (B,), optional
        The table of ``pair`` that each game reads (default: game b reads table b).
    perm : ndarray of int, shape (B, K), optional
        Variable k of game b is variable ``perm[b, k]`` of its table (default: the
        identity); its valid variables must map onto the table's first ``n_valid[b]``:
        ``W_b[k, x, l, c] = pair[table[b], perm[b, k], x, perm[b, l], c]``. The sweeps still
        update the game's variables in the game's order, but each pair field is summed in
        the table's order: a game's results depend on its table's order (not on the other
        games reading the same table).
    wide_min : int, default :data:`WIDE_SUM_MIN`
        Float32 games of at least this many valid entries sum in float64 ("Wide sums").

    Returns
    -------
    marginals : ndarray, shape (B, K, A)
        Zero at padding and invalid actions.
    iterations : ndarray of int64, shape (B,)
    kl : ndarray of float64, shape (B,)
    """
    b, k_vars, a = logits.shape
    dt = logits.dtype
    q = np.zeros((b, k_vars, a), dtype=dt)
    its = np.zeros(b, dtype=np.int64)
    kls = np.zeros(b, dtype=np.float64)
    if b == 0:
        return q, its, kls
    has_pair = pair is not None
    w = np.ascontiguousarray(pair) if has_pair else np.zeros((1, 1, 1, 1, 1), dtype=dt)
    table = np.arange(b) if table is None or not has_pair else np.asarray(table, np.int64)
    perm = np.broadcast_to(np.arange(k_vars), (b, k_vars)) if perm is None else perm
    n_valid = np.ascontiguousarray(n_valid, dtype=np.int64)
    parallel = in_parallel(b, (k_vars * a) ** 2 if has_pair else 0)
    games, tasks = _tasks(table, n_valid, numba.get_num_threads() if parallel else 1)
    args = (
        tasks,
        games,
        np.ascontiguousarray(logits),
        w,
        table,
        np.ascontiguousarray(perm, dtype=np.int64),
        n_valid,
        has_pair,
        dt.type(beta),
        float(delta),
        int(max_iter),
        int(wide_min) if dt == np.float32 else np.iinfo(np.int64).max,  # float64: as wide
        q,
        its,
        kls,
    )
    if not parallel:
        _solve_serial(*args)
    else:
        with POOL_LOCK:
            _solve_parallel(*args)
    return q, its, kls


POOL_LOCK = threading.Lock()
"""Numba's default (workqueue) thread pool must not be entered by two threads at once: every
parallel kernel of the package (this engine, the coverage kernel) runs under this lock."""


@contextmanager
def pool(parallel: bool = True, threads: int | None = None):
    """Run the parallel kernels called inside under :data:`POOL_LOCK`, on ``threads``
    threads (default: as many as now), or on the calling thread alone when ``parallel`` is
    false. One thread wakes no worker: on the 2-core virtual machine a launch of a parallel
    region costs 60-70 µs on two threads (the sleeping worker's wake-up, more when the host
    is busy) and 1-2 µs on one, so a small batch (one UAV deciding alone) runs on one. Every
    kernel gives the same results on any number of threads."""
    with POOL_LOCK:
        before = numba.get_num_threads()
        want = before if threads is None else int(threads)
        numba.set_num_threads(max(1, min(want, numba.config.NUMBA_NUM_THREADS)) if parallel else 1)
        try:
            yield
        finally:
            numba.set_num_threads(before)
