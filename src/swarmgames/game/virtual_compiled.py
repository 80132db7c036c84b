"""Compiled membership test of :func:`~swarmgames.game.virtual.member_columns` (Numba).

Where each robot of each member's reported neighbourhood N_j sits in its local game is asked
B·K·L times a stage (every game, member and entry of N_j). One binary search per entry over
all games' sorted members costs O(log(B K)) cache misses each; this kernel instead writes
each game's members into a lookup table indexed by robot id, answers the game's K·L entries
from it, and clears the K entries again: O(K + K L) per game, the games spread over threads
in fixed chunks, each with its own table (so the result does not depend on the thread count).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from swarmgames.game.meanfield_compiled import PARALLEL_MIN_GAMES, pool

__all__ = ["compiled_member_columns"]

_CHUNKS = 64
"""Chunks of games (each with its own lookup table of one entry per robot id)."""


@njit(cache=True, nogil=True, parallel=True)
def _member_columns(members, mask, nbh, span, out):
    n_b, n_k = members.shape
    n_l = nbh.shape[2]
    chunks = min(n_b, _CHUNKS)
    for c in prange(chunks):
        lookup = np.full(span, -1, dtype=np.int64)
        for b in range(c * n_b // chunks, (c + 1) * n_b // chunks):
            for k in range(n_k):  # the first column of a robot listed twice, as a stable sort
                if mask[b, k] and lookup[members[b, k]] < 0:
                    lookup[members[b, k]] = k
            for k in range(n_k):
                for m in range(n_l):
                    v = nbh[b, k, m]
                    out[b, k, m] = lookup[v] if v >= 0 else -1
            for k in range(n_k):
                if mask[b, k]:
                    lookup[members[b, k]] = -1


def compiled_member_columns(members: np.ndarray, mask: np.ndarray, nbh: np.ndarray) -> np.ndarray:
    """:func:`~swarmgames.game.virtual.member_columns` of non-empty int64 ``members`` (B, K)
    and ``nbh`` (B, K, L) with non-negative ids at valid entries, bit for bit."""
    members = np.ascontiguousarray(members, dtype=np.int64)
    nbh = np.ascontiguousarray(nbh, dtype=np.int64)
    mask = np.ascontiguousarray(mask, dtype=np.bool_)
    span = int(max(members.max(initial=0), nbh.max(initial=0))) + 1
    out = np.empty(nbh.shape, dtype=np.int64)
    with pool(members.shape[0] >= PARALLEL_MIN_GAMES):
        _member_columns(members, mask, nbh, span, out)
    return out
