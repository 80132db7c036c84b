"""Best-response refinement: from any pure profile to a pure Nash equilibrium, verified.

Every player of a local game is scored by the same :math:`M_i` (eq. 1), so the local game is
an exact potential game with potential :math:`M_i` [2]_. Best-response dynamics from any
profile therefore stop at a pure Nash equilibrium: a variable switches only on a strict
gain, every switch raises :math:`M_i`, and a finite game has finitely many profiles [2]_.

:func:`refine_profiles` runs those dynamics *from a given profile* (the mean-field argmax
profile of Algorithm 1, for ``game.refine = "best_response"``; the unary argmax for the
best-response solver): sweeps k = 0, 1, ..., K − 1 (Gauss-Seidel order), each variable
moving to its best action given the others' current actions, until a sweep changes nothing.

Exactness
---------
The stopping test is :func:`~swarmgames.game.equilibrium.deviation_gains`, the computation
of :func:`~swarmgames.game.equilibrium.local_regret` itself, on the whole batch: a game is
done when its gains are exactly 0 there, so the local regret measured afterwards at the
refined profile is exactly 0 (not merely below a tolerance), in float64 and in float32
tables. Only the games with a positive gain are swept, each variable's field computed with
the arithmetic of that test (the same gather and the same summation over the other
variables); should a sub-batch's rounding ever disagree with the whole batch's, the games
left are swept on the whole batch's fields. With a :class:`~swarmgames.game.potentials.
PairSource` the fields come from ``pair_source.at`` of the games being swept: no
``(B, K, A, K, A)`` table is built.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, section II.C (the local game and its NE).
.. [2] D. Monderer and L. S. Shapley, "Potential Games", Games and Economic Behavior 14,
   124-143, 1996: every finite (exact) potential game has the finite improvement property,
   so best-response dynamics end at a pure Nash equilibrium.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from swarmgames.arrays import freeze_fields
from swarmgames.game.equilibrium import _check_profile, _fields, deviation_gains
from swarmgames.game.potentials import GamePayoffs
from swarmgames.names import REFINE_METHODS

__all__ = ["REFINE_MAX_SWEEPS", "REFINE_METHODS", "Refinement", "refine_profiles"]

#: Sweeps after which a game counts as not converged (a finite potential game never needs
#: them; the cap only bounds a cycle that rounding could make between near-equal payoffs).
REFINE_MAX_SWEEPS = 1000


@dataclass(frozen=True, eq=False)
class Refinement:
    """Result of :func:`refine_profiles` on B games.

    Parameters
    ----------
    profile : ndarray of int64, shape (B, K)
        The refined profile: a pure NE of each converged game; 0 at padding.
    sweeps : ndarray of int64, shape (B,)
        Sweeps until the first sweep without a switch, that sweep included (1: the start was
        already a pure NE, verified by the stopping test alone).
    moves : ndarray of int64, shape (B,)
        Variables switched (0: the start was a pure NE).
    converged : ndarray of bool, shape (B,)
        Every deviation gain is exactly 0 at ``profile``.
    time_s : float
        Wall time, seconds.
    """

    profile: np.ndarray
    sweeps: np.ndarray
    moves: np.ndarray
    converged: np.ndarray
    time_s: float

    def __post_init__(self) -> None:
        freeze_fields(self)


def _field_row(payoffs: GamePayoffs, x: np.ndarray, k: int) -> np.ndarray:
    """``E[M | X_k = a]`` with the others at ``x``, (G, A) float64: row k of
    :func:`~swarmgames.game.equilibrium._fields` computed the same way."""
    if payoffs.pair is not None:
        g, n_k, a = payoffs.shape
        # W[b, k, a, l, x_l] gathered into a C-ordered (G, A, K) array and summed over l, as
        # pair_at's (G, K, A, K) gather is: the same per-row summation.
        idx = np.broadcast_to(x[:, None, :, None], (g, a, n_k, 1))
        at = np.take_along_axis(payoffs.pair[:, k], idx, axis=3)[..., 0]
        return payoffs.unary[:, k].astype(np.float64) + at.sum(axis=2)
    if payoffs.pair_source is not None:
        return _fields(payoffs, x)[:, k]
    return payoffs.unary[:, k].astype(np.float64)


def _sweeps(
    payoffs: GamePayoffs, x: np.ndarray, live: np.ndarray, budget: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Best-response sweeps of the ``live`` games of ``payoffs`` from ``x`` (updated in
    place), at most ``budget`` sweeps each; returns the sweeps run, the switches and whether
    a sweep without a switch ended each game."""
    g, n_k, _ = payoffs.shape
    rows = np.arange(g)
    sweeps = np.zeros(g, dtype=np.int64)
    moves = np.zeros(g, dtype=np.int64)
    stable = np.zeros(g, dtype=bool)
    active = live & (budget > 0)
    amask, mask = payoffs.action_mask, payoffs.mask
    while active.any():
        changed = np.zeros(g, dtype=bool)
        for k in range(n_k):
            on = mask[:, k] & active
            if not on.any():
                continue
            field = _field_row(payoffs, x, k)
            best = np.where(amask[:, k], field, -np.inf).argmax(axis=1)
            gain = field[rows, best] - field[rows, x[:, k]]
            switch = on & (gain > 0)
            x[switch, k] = best[switch]
            changed |= switch
            moves += switch
        sweeps += active
        stable |= active & ~changed
        active &= changed & (sweeps < budget)
    return sweeps, moves, stable


def refine_profiles(payoffs: GamePayoffs, start, max_iter: int = REFINE_MAX_SWEEPS) -> Refinement:
    """Best-response dynamics from ``start`` until no variable of any game gains.

    Parameters
    ----------
    payoffs : GamePayoffs
        The weighted tables (held, or on demand through ``pair_source``).
    start : array_like of int, shape (B, K)
        The profile to refine (every valid variable at a valid action; padding ignored).
    max_iter : int
        Sweeps per game at most, >= 1.

    Returns
    -------
    Refinement
        A game whose ``start`` is already a pure NE keeps it unchanged (``moves`` 0,
        ``sweeps`` 1); every converged game has local regret exactly 0 at ``profile``.

    Raises
    ------
    ValueError
        ``max_iter`` not an integer >= 1, or ``start`` of the wrong shape or with an
        invalid action.

    Examples
    --------
    >>> import numpy as np
    >>> from swarmgames.game import GamePayoffs, local_regret
    >>> u = np.zeros((1, 2, 2))
    >>> w = np.zeros((1, 2, 2, 2, 2))
    >>> w[0, 0, 1, 1, 1] = w[0, 1, 1, 0, 1] = 1.0   # both gain by meeting at action 1
    >>> ok = np.ones((1, 2), bool)
    >>> pay = GamePayoffs(u, w, np.ones((1, 2, 2), bool), ok, np.zeros(1, int), np.array([[0, 1]]))
    >>> ref = refine_profiles(pay, [[1, 0]])
    >>> ref.profile.tolist(), ref.moves.tolist(), local_regret(pay, ref.profile).tolist()
    ([[1, 1]], [1], [0.0])
    """
    if isinstance(max_iter, bool) or not isinstance(max_iter, (int, np.integer)) or max_iter < 1:
        raise ValueError(f"max_iter must be an integer >= 1 (got {max_iter})")
    t0 = time.perf_counter()
    x = _check_profile(payoffs, start).copy()
    b = x.shape[0]
    sweeps = np.ones(b, dtype=np.int64)  # the stopping test verifies a start that is a NE
    moves = np.zeros(b, dtype=np.int64)
    todo = np.flatnonzero(deviation_gains(payoffs, x).max(axis=1, initial=0.0) > 0)
    sweeps[todo] = 0
    whole = False
    while todo.size:
        budget = int(max_iter) - sweeps[todo]
        if not (budget > 0).any():
            break
        if whole:  # the whole batch's fields, the stopping test's own arithmetic
            live = np.zeros(b, dtype=bool)
            live[todo] = True
            full_budget = np.zeros(b, dtype=np.int64)
            full_budget[todo] = budget
            s, m, _ = _sweeps(payoffs, x, live, full_budget)
            sweeps += s
            moves += m
        else:
            xs = x[todo]
            s, m, _ = _sweeps(payoffs.select(todo), xs, np.ones(todo.size, bool), budget)
            x[todo] = xs
            sweeps[todo] += s
            moves[todo] += m
        todo = np.flatnonzero(deviation_gains(payoffs, x).max(axis=1, initial=0.0) > 0)
        whole = True
    converged = np.ones(b, dtype=bool)
    converged[todo] = False
    return Refinement(
        profile=x,
        sweeps=np.where(converged, sweeps, int(max_iter)),
        moves=moves,
        converged=converged,
        time_s=time.perf_counter() - t0,
    )
