"""Co-located robots: seeded tie-breaking so that robots sharing a state separate.

Robots whose states coincide are interchangeable: each builds the same local game from the
same neighbourhood, so every solver gives them the same action, and they fly in lockstep for
ever (robots that all take off from one point never separate). :func:`separate_colocated`
breaks the tie: the robots of each group of coinciding states take *distinct* actions, in
the order of preference of their marginals, the order among the robots drawn from the
stage's Generator. After one stage they stand apart and their games differ.

Nothing changes, and nothing is drawn, when no two robots coincide.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_array
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from swarmgames.rng import as_generator

__all__ = ["COLOCATED_TOL", "colocated_groups", "separate_colocated"]

#: Largest difference of any state coordinate between robots that count as co-located.
COLOCATED_TOL = 1e-6


def colocated_groups(
    states: np.ndarray, tol: float = COLOCATED_TOL, swarm: np.ndarray | None = None
) -> list[np.ndarray]:
    """Groups of two or more robots whose states differ by at most ``tol`` in every
    coordinate (linked transitively), each sorted, in order of their first robot;
    ``swarm`` (N,) int: robots of different swarms never share a group.

    Examples
    --------
    >>> colocated_groups(np.array([[0.0, 0.0], [5.0, 0.0], [0.0, 0.0]]))
    [array([0, 2])]
    """
    st = np.asarray(states, dtype=float)
    if swarm is not None:  # a label column: different swarms differ by >= 1 > tol there
        st = np.column_stack([st, np.asarray(swarm, dtype=float)])
    n = st.shape[0]
    if n < 2:
        return []
    pairs = cKDTree(st).query_pairs(float(tol), p=np.inf, output_type="ndarray")
    if len(pairs) == 0:
        return []
    graph = coo_array((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    labels = connected_components(graph, directed=False)[1]
    sizes = np.bincount(labels)
    order = np.argsort(labels, kind="stable")
    split = np.split(order, np.cumsum(sizes)[:-1])
    return sorted((g for g in split if g.size > 1), key=lambda g: int(g[0]))


def separate_colocated(
    states: np.ndarray,
    actions: np.ndarray,
    marginals: np.ndarray,
    action_mask: np.ndarray,
    rng: int | np.random.Generator | None = None,
    tol: float = COLOCATED_TOL,
    swarm: np.ndarray | None = None,
) -> np.ndarray:
    """Distinct actions for the robots of every group of coinciding states.

    In each group (:func:`colocated_groups`) the valid actions are ranked by the members'
    mean marginal (ties to the lower index) and the members, in an order drawn from ``rng``,
    take the first, second, ... of them (cycling when the group has more robots than
    actions). The first robot drawn keeps the group's preferred action.

    Parameters
    ----------
    states : ndarray, shape (N, D)
    actions : ndarray of int, shape (N,)
        The actions decided; robots in no group keep theirs.
    marginals : ndarray, shape (N, A)
        Every robot's own marginal (its variable in its game).
    action_mask : ndarray of bool, shape (N, A)
        Valid actions of every robot.
    rng : int, Generator, None, or sequence of Generator
        One permutation per group; nothing is drawn when no robots coincide. With ``swarm``,
        a sequence: the group of swarm ``e`` draws from ``rng[e]``.
    tol : float
        See :func:`colocated_groups`.
    swarm : ndarray of int, shape (N,), optional
        The swarm of every robot (:attr:`~swarmgames.game.problem.StageProblem.swarms`):
        robots of different swarms are never tied.

    Returns
    -------
    ndarray of int64, shape (N,)
        A new array.

    Examples
    --------
    >>> q = np.tile([0.1, 0.6, 0.3], (3, 1))
    >>> separate_colocated(np.zeros((3, 2)), np.ones(3, int), q, np.ones((3, 3), bool), 0)
    array([2, 0, 1])
    """
    out = np.array(actions, dtype=np.int64)
    groups = colocated_groups(states, tol, swarm)
    if not groups:
        return out
    gens = [as_generator(g) for g in rng] if swarm is not None else None
    gen = as_generator(rng) if gens is None else None
    q = np.asarray(marginals, dtype=float)
    mask = np.asarray(action_mask, dtype=bool)
    for members in groups:
        valid = mask[members].all(axis=0)
        if not valid.any():
            continue
        pref = np.where(valid, q[members].mean(axis=0), -np.inf)
        ranked = np.argsort(-pref, kind="stable")[: int(valid.sum())]
        draw = gen if gens is None else gens[int(swarm[members[0]])]
        drawn = draw.permutation(members)
        out[drawn] = ranked[np.arange(drawn.size) % ranked.size]
    return out
