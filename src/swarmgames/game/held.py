"""A batch's float64 pairwise tables held once for every group of equal games.

In a dense swarm the local games of a batch hold the same rows (robots in their states), in
another order (each game starts with its owner). Their float64 tables are then equal up to
that order (:mod:`~swarmgames.game.equal`), for any potentials whose table entries depend on
their two variables alone; a reordered copy per game would
take 58 MB at K = 300, streamed from memory by every mean-field sweep. :class:`HeldPairs`
holds one weighted table per group, in the order of the game it was computed for, and
serves it as a :class:`~swarmgames.game.potentials.PairSource` that ranks its games' variables
(``shared``, ``ranked_table``): the compiled engine solves every game of a group on the one
table, the games in step.

A group's first game (its head) reads the table in its own order, so its results are those
of its own table bit for bit; the other games sum their pair fields in the head's order,
which changes their last bits. Potentials that build it declare from which size
(``held_sharing_min``; the coverage mission: :data:`HELD_SHARE_MIN` valid entries, so that
the 7-UAV golden runs' games keep their own tables).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numba import njit, prange

from swarmgames.game.capabilities import PairSourceCapabilities
from swarmgames.game.meanfield_compiled import in_parallel, pool

__all__ = ["HELD_SHARE_MIN", "HeldPairs"]

HELD_SHARE_MIN = 1024
"""Valid entries (valid variables × actions) from which equal float64 games share a table."""


@dataclass(frozen=True, eq=False)
class HeldPairs:
    """Weighted float64 pairwise tables, one per group of equal games.

    Parameters
    ----------
    tables : ndarray of float64, shape (R, K, A, K, A)
        W of every group, in the order of the variables of the game it was computed for
        (the group's table game), weighted and zero outside the valid entries.
    group : ndarray of int64, shape (B,)
        The group (table) of every game.
    var : ndarray of int64, shape (B, K)
        Variable ``var[b, k]`` of the group's table game is variable k of game b (its valid
        variables; any value at padding).
    mask : ndarray of bool, shape (B, K)
        Valid variables of every game.
    table_valid : ndarray of bool, shape (R, K)
        Valid variables of every table game.
    """

    tables: np.ndarray
    group: np.ndarray
    var: np.ndarray
    mask: np.ndarray
    table_valid: np.ndarray

    #: ``shared`` and ``ranked_table``.
    capabilities: ClassVar[PairSourceCapabilities] = PairSourceCapabilities(shared=True)

    def table(self, games: np.ndarray) -> np.ndarray:
        """W of ``games`` in their own order, (G, K, A, K, A), a new array."""
        games = np.asarray(games, dtype=np.int64).reshape(-1)
        out = np.empty((games.size, *self.tables.shape[1:]), dtype=self.tables.dtype)
        for i, g in enumerate(games):
            v, pad = self.var[g], ~self.mask[g]
            out[i] = self.tables[self.group[g]].take(v, axis=0).take(v, axis=2)
            out[i][pad] = 0.0
            out[i][:, :, pad] = 0.0
        return out

    def at(self, profile: np.ndarray) -> np.ndarray:
        """``W[b, k, a, l, profile[b, l]]``, (B, K, A, K): gathered from the group tables by
        one compiled pass (0 where k or l is padding)."""
        b, k = self.var.shape
        out = np.empty((b, k, self.tables.shape[2], k), dtype=self.tables.dtype)
        group, var, x = (
            np.ascontiguousarray(v, dtype=np.int64) for v in (self.group, self.var, profile)
        )
        with pool(in_parallel(b, k * k * self.tables.shape[2])):
            _held_at(self.tables, group, var, np.ascontiguousarray(self.mask), x, out)
        return out

    def select(self, games) -> HeldPairs:
        """The source of a subset of games."""
        games = np.arange(self.group.size)[games]
        used, group = np.unique(self.group[games], return_inverse=True)
        return HeldPairs(
            self.tables[used], group.reshape(-1), self.var[games], self.mask[games],
            self.table_valid[used],
        )  # fmt: skip

    @property
    def _table_rank(self) -> np.ndarray:
        """Canonical position of every table game's variable: the valid ones first, in order."""
        order = np.argsort(~self.table_valid, axis=1, kind="stable")
        rank = np.empty_like(order)
        rank[np.arange(order.shape[0])[:, None], order] = np.arange(order.shape[1])
        return rank

    def shared(self) -> tuple[np.ndarray, np.ndarray]:
        """``(head, rank)`` of the :class:`~swarmgames.game.potentials.PairSource` protocol:
        the first game of every group, and every variable's canonical position in its
        group's table (padding after the valid variables, in order)."""
        b = self.var.shape[0]
        first = np.full(self.tables.shape[0], b, dtype=np.int64)
        np.minimum.at(first, self.group, np.arange(b))
        trank = self._table_rank[self.group]  # (B, K)
        rank = np.take_along_axis(trank, np.where(self.mask, self.var, 0), axis=1)
        # Padding takes the positions after the valid ones, in order.
        nv = self.mask.sum(axis=1)
        pad = np.cumsum(~self.mask, axis=1) - 1 + nv[:, None]
        rank = np.where(self.mask, rank, pad)
        return first[self.group], rank

    def ranked_table(self, games: np.ndarray) -> np.ndarray:
        """The tables of ``games``' groups in rank order, (G, K, A, K, A) (the table game's
        own order when its valid variables come first). One group whose table is in rank
        order already (every table game of a dense swarm) is served as a view of the held
        table, which the engines only read (a copy of its 58 MB at K = 300 would take about
        10 ms, for the solve and again for the refinement of every batch); else a new
        array."""
        games = np.asarray(games, dtype=np.int64).reshape(-1)
        ranks = self._table_rank
        if games.size == 1:
            r = int(self.group[games[0]])
            if np.array_equal(ranks[r], np.arange(ranks.shape[1])):
                return self.tables[r : r + 1]
        out = np.empty((games.size, *self.tables.shape[1:]), dtype=self.tables.dtype)
        for i, g in enumerate(games):
            r = self.group[g]
            order = np.argsort(ranks[r])
            out[i] = self.tables[r].take(order, axis=0).take(order, axis=2)
        return out


@njit(cache=True, nogil=True, parallel=True)
def _held_at(tables, group, var, mask, x, out):
    """``out[b, k, a, l] = tables[group[b], var[b, k], a, var[b, l], x[b, l]]`` where k and l
    are valid variables of game b, +0 elsewhere."""
    n_b, n_k = var.shape
    n_a = tables.shape[2]
    for b in prange(n_b):
        t = tables[group[b]]
        for k in range(n_k):
            if not mask[b, k]:
                out[b, k] = 0.0
                continue
            vk = var[b, k]
            for a in range(n_a):
                row = out[b, k, a]
                for m in range(n_k):
                    row[m] = t[vk, a, var[b, m], x[b, m]] if mask[b, m] else 0.0
