"""Virtual mean neighbours (paper eq. 3).

A neighbour j of robot i whose own neighbourhood reaches outside i's (N_j − N_i ≠ ∅) is
replaced in i's local game by a virtual robot at the mean state of its neighbourhood,

    S̄_j = (1 / |N_j|) Σ_{k ∈ N_j} S_k,                                      (eq. 3)

so that i's local game stands in for the influence of robots i cannot see. Robot j computes
S̄_j from the states its own neighbours reported to it and sends it to i with its
neighbourhood; i only tests N_j ⊆ N_i.

Besides eq. 3 (``"eq3"``) a local game can stand in for the outside in three other ways
(:data:`~swarmgames.names.VIRTUAL_MEANS`, :func:`virtual_mode`):

``"outside"``
    j becomes a virtual robot at the mean of the states of N_j − N_i only,
    S̄_j^out = (|N_j| S̄_j − Σ_{k ∈ N_j ∩ N_i} S_k) / |N_j − N_i| (:func:`outside_means`):
    robot i computes it from j's message (S̄_j, N_j) and its own copies of the S_k of its
    neighbourhood, with no extra communication.
``"exact"``
    no virtual robot: the robots of ∪_{j ∈ N_i} N_j − N_i enter the game as fixed context
    (their reported states, a single action that keeps them there), so that they appear in
    the members' potentials themselves (:func:`~swarmgames.game.local.build_local_games`);
    it needs their states, which a communication model delivers over 2h hops.
``"off"``
    every member keeps its reported state (the paper's comparison without eq. 3).

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, section II.C, eq. 3 and Algorithm 1, line 3.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from swarmgames.names import VIRTUAL_MEANS

__all__ = [
    "VIRTUAL_MEANS",
    "member_columns",
    "neighbourhood_means",
    "outside_means",
    "reaches_outside",
    "virtual_mode",
]


def virtual_mode(value) -> str:
    """The variant ``value`` names: one of :data:`VIRTUAL_MEANS`, with ``True`` for
    ``"eq3"`` and ``False`` for ``"off"`` (a boolean is shorthand for these two).

    Examples
    --------
    >>> virtual_mode(True), virtual_mode(False), virtual_mode("outside")
    ('eq3', 'off', 'outside')
    """
    if isinstance(value, (bool, np.bool_)):
        return "eq3" if value else "off"
    if isinstance(value, str) and value in VIRTUAL_MEANS:
        return value
    raise ValueError(
        f"virtual_mean must be one of {', '.join(map(repr, VIRTUAL_MEANS))}, true (= 'eq3') "
        f"or false (= 'off') (got {value!r})"
    )


def neighbourhood_means(neighbourhoods: sp.csr_array, states: np.ndarray) -> np.ndarray:
    """S̄_j of eq. 3 for every robot j: the mean of the states in N_j (j included).

    Parameters
    ----------
    neighbourhoods : scipy.sparse.csr_array of bool, shape (N, N)
        Row j marks N_j; every row must be non-empty (N_j always contains j).
    states : ndarray, shape (N, D)

    Returns
    -------
    ndarray, shape (N, D)

    Examples
    --------
    >>> import numpy as np, scipy.sparse as sp
    >>> a = sp.csr_array(np.array([[1, 1, 0], [1, 1, 1], [0, 1, 1]], dtype=bool))
    >>> neighbourhood_means(a, np.array([[0.0], [3.0], [6.0]])).ravel().tolist()
    [1.5, 3.0, 4.5]
    """
    counts = np.diff(neighbourhoods.indptr)
    if np.any(counts == 0):
        raise ValueError(
            f"every neighbourhood must contain its robot (robot {int(np.argmin(counts))} has "
            "an empty one)"
        )
    sums = neighbourhoods.astype(float) @ np.asarray(states, dtype=float)
    return sums / counts[:, None]


def member_columns(
    members: np.ndarray, mask: np.ndarray, member_neighbourhoods: np.ndarray
) -> np.ndarray:
    """Where each robot of each member's N_j sits in its local game: the column of that robot
    in ``members``, or -1 when it is not a variable of the game (or at padding).

    Parameters
    ----------
    members : ndarray of int, shape (B, K)
        Robot ids of the local game's variables (N_i), ``-1`` at padding.
    mask : ndarray of bool, shape (B, K)
    member_neighbourhoods : ndarray of int, shape (B, K, L)
        N_j as reported by each member j, ``-1`` padded.

    Returns
    -------
    ndarray of int64, shape (B, K, L)

    Examples
    --------
    >>> members = np.array([[4, 2, -1]])
    >>> member_columns(members, members >= 0, np.array([[[2, 4, 7], [2, -1, -1], [-1] * 3]]))
    array([[[ 1,  0, -1],
            [ 1, -1, -1],
            [-1, -1, -1]]])
    """
    members = np.asarray(members, dtype=np.int64)
    nbh = np.asarray(member_neighbourhoods, dtype=np.int64)
    if members.shape[0] == 0 or nbh.size == 0 or members.size == 0:
        return np.full(nbh.shape, -1, dtype=np.int64)
    from swarmgames.game.virtual_compiled import compiled_member_columns

    return compiled_member_columns(members, mask, nbh)


def reaches_outside(
    members: np.ndarray, mask: np.ndarray, member_neighbourhoods: np.ndarray
) -> np.ndarray:
    """Whether N_j − N_i ≠ ∅ for every variable j of every local game i.

    Parameters
    ----------
    members, mask, member_neighbourhoods
        As :func:`member_columns`.

    Returns
    -------
    ndarray of bool, shape (B, K)
        False at padding.
    """
    nbh = np.asarray(member_neighbourhoods, dtype=np.int64)
    if np.shape(members)[0] == 0 or nbh.size == 0:
        return np.zeros(np.shape(members), dtype=bool)
    col = member_columns(members, mask, nbh)
    return np.any((nbh >= 0) & (col < 0), axis=2) & np.asarray(mask, dtype=bool)


def outside_means(
    members: np.ndarray,
    mask: np.ndarray,
    states: np.ndarray,
    mean_states: np.ndarray,
    member_neighbourhoods: np.ndarray,
) -> np.ndarray:
    """S̄_j^out, the mean of the states of N_j − N_i, for every variable j of every game i.

    Robot i knows S̄_j and N_j from j's message and the states S_k of its own members, so

        S̄_j^out = (|N_j| S̄_j − Σ_{k ∈ N_j ∩ N_i} S_k) / |N_j − N_i|

    needs no communication beyond eq. 3's. It is exact when i's copies of the S_k are the
    states j averaged (exact, instant delivery); with delayed delivery the difference between
    the two enters S̄_j^out, multiplied by |N_j ∩ N_i| / |N_j − N_i| (docs/game.md).

    Parameters
    ----------
    members, mask : ndarray, shape (B, K)
    states, mean_states : ndarray, shape (B, K, D)
        The members' reported S_j and S̄_j (eq. 3).
    member_neighbourhoods : ndarray of int, shape (B, K, L)
        Their reported N_j, ``-1`` padded.

    Returns
    -------
    ndarray, shape (B, K, D)
        S̄_j^out where N_j − N_i ≠ ∅, S̄_j elsewhere (where it is not used).

    Examples
    --------
    >>> members = np.array([[1, 0, 2]])      # N_1 on the line 0-1-2-3, h = 1
    >>> nbh = np.array([[[0, 1, 2], [0, 1, -1], [1, 2, 3]]])
    >>> s = np.array([[[1.0], [0.0], [2.0]]])
    >>> mean = np.array([[[1.0], [0.5], [2.0]]])  # S̄_2 = (S_1 + S_2 + S_3) / 3 with S_3 = 3
    >>> outside_means(members, members >= 0, s, mean, nbh)[0, 2].tolist()
    [3.0]
    """
    states = np.asarray(states, dtype=float)
    mean_states = np.asarray(mean_states, dtype=float)
    nbh = np.asarray(member_neighbourhoods, dtype=np.int64)
    if states.shape[0] == 0 or nbh.size == 0:
        return mean_states.copy()
    col = member_columns(members, mask, nbh)
    inside = col >= 0
    size = (nbh >= 0).sum(axis=2)
    n_out = size - inside.sum(axis=2)
    games = np.arange(states.shape[0])[:, None, None]
    copies = np.where(inside[..., None], states[games, np.maximum(col, 0)], 0.0)
    total = size[..., None] * mean_states - copies.sum(axis=2)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = total / np.maximum(n_out, 1)[..., None]
    return np.where((n_out > 0)[..., None], out, mean_states)
