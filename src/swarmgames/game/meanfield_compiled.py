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

# A stage launches dozens of short parallel regions between numpy steps. OpenMP's default
# wait policy keeps idle workers spinning after each, taking the core the Python thread
# needs next: on the 2-core machine a N = 1 000 stage took 0.9 s on two threads against
# 0.55 s on one. Passive workers sleep (0.53 s on two threads). Read when Numba's OpenMP
# layer starts (the first parallel launch); a value the user set is kept.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import numpy as np
from numba import njit, prange

__all__ = ["POOL_LOCK", "solve_batch"]


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
    """Σ_i row[i] q[i] over the first n entries (vectorised; order fixed by n)."""
    s = row.dtype.type(0.0)
    for i in range(n):
        s += row[i] * q[i]
    return s


@njit(cache=True, nogil=True)
def _solve_game(logits, w, nv, has_pair, beta, delta, max_iter, q_out):
    """Mean-field sweeps of one game until KL < delta or ``max_iter`` sweeps.

    logits : (K, A), β·U with -inf at invalid actions; w : (K, A, K, A) pair table; the first
    ``nv`` variables are the valid ones. Writes Q into ``q_out`` (K, A); returns (sweeps, KL).
    """
    a = logits.shape[1]
    n = nv * a
    q = np.zeros(n, logits.dtype)
    q_old = np.empty(n, logits.dtype)
    z = np.empty(a, logits.dtype)
    wf = w.reshape((w.shape[0] * w.shape[1], w.shape[2] * w.shape[3]))
    for k in range(nv):
        for x in range(a):
            z[x] = logits[k, x]
        _softmax_into(z, q, k * a)
    it = 0
    kl = np.inf
    while it < max_iter:
        it += 1
        q_old[:] = q
        for k in range(nv):
            off = k * a
            for x in range(a):
                if has_pair:
                    # β·(Σ W Q) + β·U, the order of the numpy engines.
                    z[x] = _dot(wf[off + x], q, n) * beta + logits[k, x]
                else:
                    z[x] = logits[k, x]
            _softmax_into(z, q, off)
        kl = 0.0
        for k in range(nv):
            s = 0.0
            for x in range(a):
                p = np.float64(q_old[k * a + x])
                if p > 0.0:
                    s += p * (np.log(p) - np.log(np.float64(q[k * a + x])))
            kl += s
        if kl < delta:
            break
    for k in range(nv):
        for x in range(a):
            q_out[k, x] = q[k * a + x]
    return it, kl


@njit(cache=True, nogil=True)
def _solve_into(g, logits, w, nv, has_pair, beta, delta, max_iter, q, its, kls):
    """Solve game ``g`` of the batch into row ``g`` of the outputs."""
    gw = g * np.int64(has_pair)  # the dummy table of a batch without pairwise term
    its[g], kls[g] = _solve_game(logits[g], w[gw], nv[g], has_pair, beta, delta, max_iter, q[g])


@njit(cache=True, nogil=True, parallel=True)
def _solve_parallel(logits, w, nv, has_pair, beta, delta, max_iter, q, its, kls):
    for g in prange(logits.shape[0]):
        _solve_into(g, logits, w, nv, has_pair, beta, delta, max_iter, q, its, kls)


@njit(cache=True, nogil=True)
def _solve_serial(logits, w, nv, has_pair, beta, delta, max_iter, q, its, kls):
    for g in range(logits.shape[0]):
        _solve_into(g, logits, w, nv, has_pair, beta, delta, max_iter, q, its, kls)


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
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Solve B games whose valid variables are a prefix of each row.

    Parameters
    ----------
    logits : ndarray, shape (B, K, A)
        β·U, ``-inf`` at invalid actions (at least one finite entry per valid variable).
    pair : ndarray, shape (B, K, A, K, A), or None
        W of :mod:`swarmgames.game.meanfield`, same dtype as ``logits``.
    n_valid : ndarray of int, shape (B,)
        Valid variables of each game (variables ``0 .. n_valid - 1``).
    beta, delta, max_iter
        As :func:`~swarmgames.game.meanfield.mean_field` (already validated).

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
    args = (
        np.ascontiguousarray(logits),
        w,
        np.ascontiguousarray(n_valid, dtype=np.int64),
        has_pair,
        dt.type(beta),
        float(delta),
        int(max_iter),
        q,
        its,
        kls,
    )
    if not in_parallel(b, (k_vars * a) ** 2 if has_pair else 0):
        _solve_serial(*args)
    else:
        with POOL_LOCK:
            _solve_parallel(*args)
    return q, its, kls


POOL_LOCK = threading.Lock()
"""Numba's default (workqueue) thread pool must not be entered by two threads at once: every
parallel kernel of the package (this engine, the coverage kernel) runs under this lock."""
