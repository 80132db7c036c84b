"""Baseline local-game solvers: exact enumeration, best-response dynamics, random play.

They work on the same :class:`~swarmgames.game.potentials.GamePayoffs` as the mean-field
solver and return pure profiles ``(B, K)``; :mod:`swarmgames.game.solvers` wraps them behind
the common ``solve(batch, potentials, rng)`` interface. The centralised and no-virtual-mean
baselines reuse the mean-field solver on a different game (see ``solvers``).

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, section II.C.
.. [2] D. Monderer and L. S. Shapley, "Potential Games", 1996: best-response dynamics in a
   finite potential game stop at a pure Nash equilibrium.
"""

from __future__ import annotations

import numpy as np

from swarmgames.game.equilibrium import enumerate_payoffs
from swarmgames.game.potentials import GamePayoffs
from swarmgames.game.refine import refine_profiles

__all__ = ["best_response", "exact_profiles", "random_profiles"]


def _masked_argmax(values: np.ndarray, mask: np.ndarray) -> np.ndarray:
    return np.where(mask, values, -np.inf).argmax(axis=-1)


def exact_profiles(payoffs: GamePayoffs, max_profiles: int = 1_000_000) -> np.ndarray:
    """The profile maximising M in every game, by enumeration (a pure NE: the maximum of a
    potential game's potential is one).

    Loops over games (a reference for small neighbourhoods, not a hot path); ties go to the
    first profile in C order of the valid actions.

    Returns
    -------
    ndarray of int, shape (B, K)
    """
    b, k, _ = payoffs.shape
    out = np.zeros((b, k), dtype=np.int64)
    for g in range(b):
        grid, actions = enumerate_payoffs(payoffs, g, max_profiles)
        best = np.unravel_index(int(np.argmax(grid)), grid.shape)
        for i, var in enumerate(np.flatnonzero(payoffs.mask[g])):
            out[g, var] = actions[i][best[i]]
    return out


def best_response(
    payoffs: GamePayoffs, max_iter: int = 200, *, start=None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Best-response dynamics: sweep k = 0..K−1, each variable switching to its best action
    given the others' current actions, from ``start`` (default: the unary argmax).

    A variable only switches on a strict improvement, so M increases with every switch and the
    dynamics stop at a pure NE in finitely many sweeps
    (:func:`~swarmgames.game.refine.refine_profiles`, which this calls; the local regret of
    a converged game is exactly 0).

    Parameters
    ----------
    payoffs : GamePayoffs
    max_iter : int
        Sweeps at most, >= 1.
    start : array_like of int, shape (B, K), optional
        The profile the dynamics start from.

    Returns
    -------
    profile : ndarray of int, shape (B, K)
    iterations : ndarray of int, shape (B,)
        Sweeps until the first sweep without a switch (or ``max_iter``).
    converged : ndarray of bool, shape (B,)
        A sweep without a switch happened.
    """
    if start is None:
        start = np.where(payoffs.mask, _masked_argmax(payoffs.unary, payoffs.action_mask), 0)
    ref = refine_profiles(payoffs, start, max_iter)
    return ref.profile.copy(), ref.sweeps.copy(), ref.converged.copy()


def random_profiles(payoffs: GamePayoffs, rng: np.random.Generator) -> np.ndarray:
    """A uniformly random valid action for every variable, (B, K)."""
    amask = payoffs.action_mask
    keys = np.where(amask, rng.random(amask.shape), -1.0)
    return np.where(payoffs.mask, keys.argmax(axis=2), 0)
