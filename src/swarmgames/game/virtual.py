"""Virtual mean neighbours (paper eq. 3).

A neighbour j of robot i whose own neighbourhood reaches outside i's (N_j − N_i ≠ ∅) is
replaced in i's local game by a virtual robot at the mean state of its neighbourhood,

    S̄_j = (1 / |N_j|) Σ_{k ∈ N_j} S_k,                                      (eq. 3)

so that i's local game stands in for the influence of robots i cannot see. Robot j computes
S̄_j from the states its own neighbours reported to it and sends it to i with its
neighbourhood; i only tests N_j ⊆ N_i.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, section II.C, eq. 3 and Algorithm 1, line 3.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = ["neighbourhood_means", "reaches_outside"]


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


def reaches_outside(
    members: np.ndarray, mask: np.ndarray, member_neighbourhoods: np.ndarray
) -> np.ndarray:
    """Whether N_j − N_i ≠ ∅ for every variable j of every local game i.

    Parameters
    ----------
    members : ndarray of int, shape (B, K)
        Robot ids of the local game's variables (N_i), ``-1`` at padding.
    mask : ndarray of bool, shape (B, K)
    member_neighbourhoods : ndarray of int, shape (B, K, L)
        N_j as reported by each member j, ``-1`` padded.

    Returns
    -------
    ndarray of bool, shape (B, K)
        False at padding.
    """
    members = np.asarray(members, dtype=np.int64)
    nbh = np.asarray(member_neighbourhoods, dtype=np.int64)
    b = members.shape[0]
    if b == 0 or nbh.size == 0:
        return np.zeros(members.shape, dtype=bool)
    span = int(max(members.max(initial=0), nbh.max(initial=0))) + 2
    # Each game's members, sorted, in its own band of ids, so that one searchsorted over the
    # flattened array answers every "is l in N_i" at once.
    sorted_members = np.sort(np.where(mask, members, span - 1), axis=1)
    offset = (np.arange(b, dtype=np.int64) * span)[:, None]
    flat = (sorted_members + offset).ravel()
    query = nbh + offset[:, :, None]
    pos = np.minimum(np.searchsorted(flat, query), flat.size - 1)
    found = flat[pos] == query
    return np.any((nbh >= 0) & ~found, axis=2) & mask
