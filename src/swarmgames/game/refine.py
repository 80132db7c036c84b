"""Best-response refinement: from any pure profile to a pure Nash equilibrium, verified.

Every player of a local game is scored by the same :math:`M_i` (eq. 1), so the local game is
an exact potential game with potential :math:`M_i` [2]_. Best-response dynamics from any
profile therefore stop at a pure Nash equilibrium: a variable switches only on a strict
gain, every switch raises :math:`M_i`, and a finite game has finitely many profiles [2]_.

:func:`refine_profiles` runs those dynamics *from a given profile* (the mean-field argmax
profile of Algorithm 1, for ``game.refine = "best_response"``; the unary argmax for the
best-response solver): sweeps k = 0, 1, ..., K − 1 (Gauss-Seidel order), each variable
moving to its best action given the others' current actions, until a sweep changes nothing.

Exactness and cost
------------------
The stopping test is :func:`~swarmgames.game.equilibrium.deviation_gains`, the computation
of :func:`~swarmgames.game.equilibrium.local_regret` itself, on the whole batch: a game is
done when its gains are exactly 0 there, so the local regret measured afterwards at the
refined profile is exactly 0 (not merely below a tolerance), in float64 and in float32
tables. Only the games with a positive gain are swept, in up to three rounds:

1. by the compiled kernel of :mod:`swarmgames.game.refine_compiled` (Numba; without it,
   numpy steps per variable with the stopping test's gather and summation), on the held
   pairwise table, or on tables of chunks of those games computed just before (a
   :class:`~swarmgames.game.potentials.PairSource`, at most ``SOURCE_CHUNK_ELEMS`` entries
   at a time, as the compiled mean-field engine does: no ``(B, K, A, K, A)`` table of the
   batch is built; with a source that ranks its games, one ranked table per group of games
   holding the same variables), whose sums may round otherwise than the stopping test's;
2. the games the stopping test still finds a gain in (a near-tie that the two roundings
   see differently) swept with the test's own fields, from ``pair_source.at``;
3. should that leave any, on the fields of the whole batch, the test's arithmetic exactly.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, section II.C (the local game and its NE).
.. [2] D. Monderer and L. S. Shapley, "Potential Games", Games and Economic Behavior 14,
   124-143, 1996: every finite (exact) potential game has the finite improvement property,
   so best-response dynamics end at a pure Nash equilibrium.
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass

import numpy as np

from swarmgames.arrays import freeze_fields
from swarmgames.game import meanfield
from swarmgames.game.equilibrium import _check_profile, _fields, deviation_gains
from swarmgames.game.potentials import GamePayoffs, ranked_chunks, shared_tables
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


def _gaining(payoffs: GamePayoffs, x: np.ndarray) -> np.ndarray:
    """Games in which some variable gains by deviating alone from ``x`` (the stopping test:
    the arithmetic of :func:`~swarmgames.game.equilibrium.local_regret`)."""
    return np.flatnonzero(deviation_gains(payoffs, x).max(axis=1, initial=0.0) > 0)


def _compiled(
    payoffs: GamePayoffs, x: np.ndarray, games: np.ndarray, budget: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The sweeps of :func:`_sweeps` for the games ``games`` of held tables, compiled
    (:mod:`swarmgames.game.refine_compiled`); ``x`` updated in place."""
    from swarmgames.game.refine_compiled import compiled_sweeps

    return compiled_sweeps(
        payoffs.unary, payoffs.pair, payoffs.action_mask, payoffs.mask, x, games, budget
    )


def _chunked_sweeps(
    payoffs: GamePayoffs, x: np.ndarray, todo: np.ndarray, budget: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Sweeps of the games ``todo`` of a batch with a pair source, on tables of chunks of
    them (at most ``SOURCE_CHUNK_ELEMS`` entries each); ``x`` updated in place."""
    _, k, a = payoffs.shape
    per = max(1, meanfield.SOURCE_CHUNK_ELEMS // max(1, (k * a) ** 2))
    source = payoffs.pair_source
    same = shared_tables(source)
    if same is not None and meanfield.compiled_available():
        return _ranked_sweeps(payoffs, x, todo, budget, same, per)
    sweeps = np.zeros(todo.size, dtype=np.int64)
    moves = np.zeros(todo.size, dtype=np.int64)
    for lo in range(0, todo.size, per):
        idx = todo[lo : lo + per]
        sub = payoffs.select(idx)
        held = GamePayoffs(
            sub.unary, sub.pair_table(), sub.action_mask, sub.mask, sub.owner, sub.members
        )
        xs = x[idx]
        if meanfield.compiled_available():
            s, m = _compiled(held, xs, np.arange(idx.size), budget[lo : lo + per])
        else:
            s, m, _ = _sweeps(held, xs, np.ones(idx.size, bool), budget[lo : lo + per])
        x[idx] = xs
        sweeps[lo : lo + per], moves[lo : lo + per] = s, m
        del held, sub  # this chunk's table is freed before the next one is built
    return sweeps, moves


def _ranked_sweeps(payoffs, x, todo, budget, same, per):
    """:func:`_chunked_sweeps` on the source's ranked tables (``PairSource.shared``), one
    per group of games holding the same variables, chunk by chunk of groups."""
    from swarmgames.game.refine_compiled import compiled_sweeps

    head, rank = same
    sweeps = np.zeros(todo.size, dtype=np.int64)
    moves = np.zeros(todo.size, dtype=np.int64)
    for sel, w, table in ranked_chunks(payoffs.pair_source, head, todo, per):
        sweeps[sel], moves[sel] = compiled_sweeps(
            payoffs.unary, w, payoffs.action_mask, payoffs.mask, x, todo[sel], budget[sel],
            table=table, perm=rank,
        )  # fmt: skip
        del w  # this chunk's tables are freed before the next ones are built
    return sweeps, moves


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
    todo = _gaining(payoffs, x)
    sweeps[todo] = 0
    for rnd in itertools.count():
        budget = int(max_iter) - sweeps[todo]
        if not todo.size or not (budget > 0).any():
            break
        if rnd == 0 and payoffs.pair is None and payoffs.pair_source is not None:
            s, m = _chunked_sweeps(payoffs, x, todo, budget)
        elif rnd == 0 and meanfield.compiled_available():
            s, m = _compiled(payoffs, x, todo, budget)
        elif rnd <= 1:
            xs = x[todo]
            s, m, _ = _sweeps(payoffs.select(todo), xs, np.ones(todo.size, bool), budget)
            x[todo] = xs
        else:  # the whole batch's fields: the stopping test's arithmetic exactly
            live = np.zeros(b, dtype=bool)
            live[todo] = True
            full = np.zeros(b, dtype=np.int64)
            full[todo] = budget
            s, m, _ = _sweeps(payoffs, x, live, full)
            s, m = s[todo], m[todo]
        sweeps[todo] += s
        moves[todo] += m
        todo = _gaining(payoffs, x)
    converged = np.ones(b, dtype=bool)
    converged[todo] = False
    return Refinement(
        profile=x,
        sweeps=np.where(converged, sweeps, int(max_iter)),
        moves=moves,
        converged=converged,
        time_s=time.perf_counter() - t0,
    )
