"""Compiled best-response sweeps (Numba): the first round of :mod:`swarmgames.game.refine`.

The numpy sweeps of :func:`~swarmgames.game.refine.refine_profiles` update variable k of all
games with a few numpy calls, a fixed cost of some tens of µs per variable and sweep that
dominates at 1 000 UAVs (games of up to 30 variables, two or three sweeps). This kernel takes
one game at a time and runs its sweeps to the end, the games spread over threads
(``numba.prange``): the same dynamics (Gauss-Seidel order, a switch only on a strict gain,
ties to the lowest action), each variable's field :math:`U[k, a] + \\sum_l W[k, a, l, x_l]`
summed in the table's precision in the order of ``l``.

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
def _sweep_game(u, w, amask, mask, x, has_pair, budget):
    """Best-response sweeps of one game from ``x`` (K,), updated in place, until a sweep
    switches nothing or ``budget`` sweeps; returns (sweeps, switches)."""
    n_k, n_a = u.shape
    sweeps = 0
    moves = 0
    while sweeps < budget:
        changed = False
        for k in range(n_k):
            if not mask[k]:
                continue
            cur = x[k]
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
                        s += w[k, a, m, x[m]]
                    f = f + np.float64(s)
                if f > best_f:
                    best_f = f
                    best_a = a
                if a == cur:
                    cur_f = f
            if best_f - cur_f > 0.0:
                x[k] = best_a
                changed = True
                moves += 1
        sweeps += 1
        if not changed:
            break
    return sweeps, moves


@njit(cache=True, nogil=True)
def _sweep_into(i, games, u, w, amask, mask, x, has_pair, budget, sweeps, moves):
    g = games[i]
    gw = g * np.int64(has_pair)  # the dummy table of games without pairwise term
    sweeps[i], moves[i] = _sweep_game(u[g], w[gw], amask[g], mask[g], x[g], has_pair, budget[i])


@njit(cache=True, nogil=True, parallel=True)
def _sweep_parallel(games, u, w, amask, mask, x, has_pair, budget, sweeps, moves):
    for i in prange(games.size):
        _sweep_into(i, games, u, w, amask, mask, x, has_pair, budget, sweeps, moves)


@njit(cache=True, nogil=True)
def _sweep_serial(games, u, w, amask, mask, x, has_pair, budget, sweeps, moves):
    for i in range(games.size):
        _sweep_into(i, games, u, w, amask, mask, x, has_pair, budget, sweeps, moves)


def compiled_sweeps(
    unary: np.ndarray,
    pair: np.ndarray | None,
    action_mask: np.ndarray,
    mask: np.ndarray,
    x: np.ndarray,
    games: np.ndarray,
    budget: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Best-response sweeps of the games ``games`` of a batch, ``x`` (B, K) int64 updated in
    place.

    Parameters
    ----------
    unary : ndarray, shape (B, K, A)
    pair : ndarray, shape (B, K, A, K, A), or None
    action_mask : ndarray of bool, shape (B, K, A)
    mask : ndarray of bool, shape (B, K)
    x : ndarray of int64, shape (B, K), C-contiguous
        The profile (valid actions on valid variables, 0 at padding).
    games : ndarray of int, shape (G,)
    budget : ndarray of int, shape (G,)
        Sweeps each game may run at most.

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
    args = (
        np.ascontiguousarray(games, dtype=np.int64),
        u,
        w,
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
