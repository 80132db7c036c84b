"""Compiled best-response sweeps (Numba): the first round of :mod:`swarmgames.game.refine`.

The numpy sweeps of :func:`~swarmgames.game.refine.refine_profiles` update variable k of all
games with a few numpy calls, a fixed cost of some tens of µs per variable and sweep that
dominates at 1 000 UAVs (games of up to 30 variables, two or three sweeps). This kernel takes
one game at a time and runs its sweeps to the end, the games spread over threads
(``numba.prange``): the same dynamics (Gauss-Seidel order, a switch only on a strict gain,
ties to the lowest action), each variable's field :math:`U[k, a] + \\sum_l W[k, a, l, x_l]`
summed in the table's precision in the order of ``l`` (or of the table's variables, when
games share a ranked table: :mod:`~swarmgames.game.meanfield_compiled`, "Shared tables").

numpy sums the same terms pairwise, so a near-tie may round otherwise here than in the
stopping test (:func:`~swarmgames.game.equilibrium.deviation_gains`); the refinement sweeps
the games the test still finds a gain in again with the test's own arithmetic, so its
result keeps local regret exactly 0.

References
----------
.. [1] D. Monderer and L. S. Shapley, "Potential Games", Games and Economic Behavior 14,
   1996 (best-response dynamics in a finite potential game end at a pure NE).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from swarmgames.game.meanfield_compiled import POOL_LOCK, in_parallel

__all__ = ["compiled_sweeps"]


@njit(cache=True, nogil=True)
def _sweep_game(u, w, perm, amask, mask, x, has_pair, budget):
    """Best-response sweeps of one game from ``x`` (K,), updated in place, until a sweep
    switches nothing or ``budget`` sweeps; returns (sweeps, switches). Variable k of the
    game is variable ``perm[k]`` of the table ``w``, whose order the pair sums follow."""
    n_k, n_a = u.shape
    xt = np.empty(n_k, np.int64)  # the profile in the table's order
    for m in range(n_k):
        xt[perm[m]] = x[m]
    sweeps = 0
    moves = 0
    while sweeps < budget:
        changed = False
        for k in range(n_k):
            if not mask[k]:
                continue
            cur = x[k]
            row = perm[k]
            best_a = -1
            best_f = -np.inf
            cur_f = 0.0
            for a in range(n_a):
                if not amask[k, a]:
                    continue
                f = np.float64(u[k, a])
                if has_pair:
                    s = w.dtype.type(0.0)
                    for m in range(n_k):
                        s += w[row, a, m, xt[m]]
                    f = f + np.float64(s)
                if f > best_f:
                    best_f = f
                    best_a = a
                if a == cur:
                    cur_f = f
            if best_f - cur_f > 0.0:
                x[k] = best_a
                xt[row] = best_a
                changed = True
                moves += 1
        sweeps += 1
        if not changed:
            break
    return sweeps, moves


@njit(cache=True, nogil=True)
def _sweep_into(i, games, u, w, table, perm, amask, mask, x, has_pair, budget, sweeps, moves):
    g = games[i]
    gw = table[i] * np.int64(has_pair)  # the dummy table of games without pairwise term
    sweeps[i], moves[i] = _sweep_game(
        u[g], w[gw], perm[g], amask[g], mask[g], x[g], has_pair, budget[i]
    )


@njit(cache=True, nogil=True, parallel=True)
def _sweep_parallel(games, u, w, table, perm, amask, mask, x, has_pair, budget, sweeps, moves):
    for i in prange(games.size):
        _sweep_into(i, games, u, w, table, perm, amask, mask, x, has_pair, budget, sweeps, moves)


@njit(cache=True, nogil=True)
def _sweep_serial(games, u, w, table, perm, amask, mask, x, has_pair, budget, sweeps, moves):
    for i in range(games.size):
        _sweep_into(i, games, u, w, table, perm, amask, mask, x, has_pair, budget, sweeps, moves)


def compiled_sweeps(
    unary: np.ndarray,
    pair: np.ndarray | None,
    action_mask: np.ndarray,
    mask: np.ndarray,
    x: np.ndarray,
    games: np.ndarray,
    budget: np.ndarray,
    table: np.ndarray | None = None,
    perm: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Best-response sweeps of the games ``games`` of a batch, ``x`` (B, K) int64 updated in
    place.

    Parameters
    ----------
    unary : ndarray, shape (B, K, A)
    pair : ndarray, shape (B, K, A, K, A) or (H, K, A, K, A), or None
        One table per game, or tables that games share (``table``, ``perm``).
    action_mask : ndarray of bool, shape (B, K, A)
    mask : ndarray of bool, shape (B, K)
    x : ndarray of int64, shape (B, K), C-contiguous
        The profile (valid actions on valid variables, 0 at padding).
    games : ndarray of int, shape (G,)
    budget : ndarray of int, shape (G,)
        Sweeps each game may run at most.
    table : ndarray of int, shape (G,), optional
        The table of ``pair`` that each of ``games`` reads (default: game g reads table g).
    perm : ndarray of int, shape (B, K), optional
        Variable k of game b is variable ``perm[b, k]`` of its table (a permutation;
        default: the identity); each field is then summed in the table's order.

    Returns
    -------
    sweeps, moves : ndarray of int64, shape (G,)
        Sweeps run (the last without a switch, unless the budget ran out) and switches.
    """
    n = games.size
    sweeps = np.zeros(n, dtype=np.int64)
    moves = np.zeros(n, dtype=np.int64)
    if n == 0:
        return sweeps, moves
    has_pair = pair is not None
    u = np.ascontiguousarray(unary)
    w = np.ascontiguousarray(pair) if has_pair else np.zeros((1, 1, 1, 1, 1), dtype=u.dtype)
    games = np.ascontiguousarray(games, dtype=np.int64)
    table = games if table is None else table
    perm = np.broadcast_to(np.arange(u.shape[1]), u.shape[:2]) if perm is None else perm
    args = (
        games,
        u,
        w,
        np.ascontiguousarray(table, dtype=np.int64),
        np.ascontiguousarray(perm, dtype=np.int64),
        np.ascontiguousarray(action_mask, dtype=np.bool_),
        np.ascontiguousarray(mask, dtype=np.bool_),
        x,
        has_pair,
        np.ascontiguousarray(budget, dtype=np.int64),
        sweeps,
        moves,
    )
    if not in_parallel(n, u[0].size ** 2 if has_pair else 0):
        _sweep_serial(*args)
    else:
        with POOL_LOCK:
            _sweep_parallel(*args)
    return sweeps, moves
