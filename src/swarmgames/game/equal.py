"""Local games that hold the same rows: their values are computed once.

A value of a local game that depends on the *set* of its rows (its robots in their states,
:mod:`~swarmgames.game.rows`) and not on their order is the same, bit for bit, for two games
that hold the same rows in another order. The coverage unary (eq. 5) is one: the others enter
through the best signal at each cell, a maximum. So is a pairwise table up to the order of its
variables: every entry is computed from its two points alone. That is the dense swarm's case:
when every robot hears every other with exact delivery, all N local games hold all N robots,
and computing once instead of N times removes a factor N from the stage's largest cost.

:func:`equal_games` finds such games from the batch's row index and returns the games to
compute and how to copy their rows back; :class:`CarriedGame` keeps one game's values for the
stage's next batch. A batch without repeated games (a spread swarm, or routed delivery where
every inbox differs) costs one sort of the row indices per game.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swarmgames.arrays import sorted_unique

__all__ = ["CarriedGame", "EqualGames", "equal_games"]


@dataclass(frozen=True)
class EqualGames:
    """Which games of a batch to compute, and where each game's rows come from.

    Attributes
    ----------
    games : ndarray of int64, shape (R,)
        One game of every group of equal games (the first), increasing.
    source : ndarray of int64, shape (B, K)
        ``source[b, k]`` is the row of ``games`` × K (flat index ``r * K + k'``) whose values
        variable ``k`` of game ``b`` takes; -1 at padding.
    """

    games: np.ndarray
    source: np.ndarray

    def rows(self, wanted: np.ndarray) -> np.ndarray:
        """The rows of the computed games that ``wanted`` (B, K) bool needs, (R, K) bool."""
        out = np.zeros(self.games.size * self.source.shape[1], dtype=bool)
        out[self.source[wanted & (self.source >= 0)]] = True
        return out.reshape(self.games.size, self.source.shape[1])

    def expand(self, values: np.ndarray, fill: float = 0.0) -> np.ndarray:
        """Every game's rows, (B, K, ...), from ``values`` (R, K, ...) of the computed games."""
        flat = values.reshape(self.games.size * values.shape[1], *values.shape[2:])
        out = flat[np.maximum(self.source, 0)]
        out[self.source < 0] = fill
        return out

    def expand_pairs(self, tables: np.ndarray, carried: np.ndarray | None = None) -> None:
        """Fill every game's pairwise table in ``tables`` (B, K, A, K, A), in place, from the
        computed games' (already there): ``tables[b, k, :, l, :]`` becomes the entry of the
        variables that ``k`` and ``l`` are in ``b``'s computed game (at padding, a copy of a
        valid entry). The computed games are left as they are. With ``carried`` (K, A, K, A),
        these games are those of :meth:`CarriedGame.match`: game 0 is the carried game,
        whose table that is, and game ``1 + b`` is ``tables[b]``."""
        b, k = self.source.shape
        off = 0 if carried is None else 1
        src = np.maximum(self.source, 0)
        head = self.games[src.max(axis=1) // k]
        var = np.where(self.source >= 0, src % k, 0)
        for g in np.flatnonzero(head != np.arange(b)):
            frm = carried if head[g] < off else tables[head[g] - off]
            tables[g - off] = frm.take(var[g], axis=0).take(var[g], axis=2)


def equal_games(rows: np.ndarray, mask: np.ndarray) -> EqualGames | None:
    """The games of a batch that repeat an earlier one, up to the order of their variables;
    ``None`` when there is none.

    Parameters
    ----------
    rows : ndarray of int, shape (B, K)
        The row of every variable (:attr:`~swarmgames.game.batch.LocalGameBatch.rows`):
        equal rows hold the same robot in the same state, with the same next states and
        valid actions; any value at padding.
    mask : ndarray of bool, shape (B, K)
        Valid variables.

    Returns
    -------
    EqualGames or None

    Examples
    --------
    Games 0 and 2 hold rows 5 and 7, in another order:

    >>> rows = np.array([[5, 7], [5, 8], [7, 5]])
    >>> d = equal_games(rows, np.ones((3, 2), bool))
    >>> d.games.tolist(), d.source.tolist()
    ([0, 1], [[0, 1], [2, 3], [1, 0]])
    """
    mask = np.asarray(mask, dtype=bool)
    b, k = mask.shape
    if b < 2:
        return None
    slot = np.where(mask, np.asarray(rows, dtype=np.int64), -1)
    # Equal games hold equal sets of rows: without a repeated set there is nothing to share.
    if not _repeated_rows(np.sort(slot, axis=1)):
        return None
    order = np.argsort(np.where(mask, slot, np.iinfo(np.int64).max), axis=1, kind="stable")
    key = np.take_along_axis(slot, order, axis=1)
    first, group = _row_groups(key)
    if first.size == b:
        return None
    games = np.sort(first).astype(np.int64)
    rank = np.empty(b, dtype=np.int64)
    rank[games] = np.arange(games.size)
    rep = rank[first[group]]  # the computed game of every game's group
    # Variable order[b, c] of game b holds the same row as variable order[rep, c] of its
    # group's computed game.
    rep_order = order[games][rep]
    source = np.full((b, k), -1, dtype=np.int64)
    source[np.arange(b)[:, None], order] = rep[:, None] * k + rep_order
    source[~mask] = -1
    return EqualGames(games=games, source=source)


#: Odd 64-bit multipliers of the columns in :func:`_repeated_rows` (Weyl sequence of the
#: golden ratio).
_COLUMN_MIX = np.uint64(0x9E3779B97F4A7C15)


def _row_hashes(rows: np.ndarray) -> np.ndarray:
    """A 64-bit hash of every row of the int array ``rows`` (R, K): the sum of its entries
    with one odd weight per column, modulo 2^64. Rows with different hashes differ."""
    with np.errstate(over="ignore"):
        weights = (np.arange(1, rows.shape[1] + 1, dtype=np.uint64) * _COLUMN_MIX) | np.uint64(1)
        return (rows.astype(np.uint64) * weights).sum(axis=1, dtype=np.uint64)


def _repeated_rows(rows: np.ndarray) -> bool:
    """Whether two rows of the int array ``rows`` (R, K) are equal: all-distinct hashes
    answer "no" at the cost of one 1-D sort; equal hashes are checked on the rows."""
    if sorted_unique(_row_hashes(rows)).size == rows.shape[0]:
        return False
    return np.unique(rows, axis=0).shape[0] < rows.shape[0]


def _row_groups(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(first, group)``: the groups of equal rows of the int array ``rows`` (R, K), as
    ``np.unique(rows, axis=0, return_index=True, return_inverse=True)`` gives them up to
    the groups' numbering (``first[g]``, the first row of group g; ``group``, every row's).
    Grouped by hash with a 1-D sort; the lexicographic sort of the rows only when two
    different rows share a hash."""
    _, first, group = np.unique(_row_hashes(rows), return_index=True, return_inverse=True)
    group = group.reshape(-1)
    if not np.array_equal(rows, rows[first[group]]):
        _, first, group = np.unique(rows, axis=0, return_index=True, return_inverse=True)
        group = group.reshape(-1)
    return first, group


@dataclass(frozen=True)
class CarriedGame:
    """One game of a batch and what was computed for it, kept for the stage's next batch.

    A stage splits its games into batches (memory-bounded), and a dense swarm's batches hold
    the same game again: all N games hold all N robots. The potentials keep the largest
    group's game and its unary rows, or its pairwise table
    (:meth:`~swarmgames.game.rows.StageRows.carry`), so that the next batch's games that hold
    the same rows take those values instead of computing them again (bit for bit the same:
    :func:`equal_games`). Row indices are those of one stage, so a game is carried only
    within its stage.

    Attributes
    ----------
    rows : ndarray of int64, shape (1, K)
    mask : ndarray of bool, shape (1, K)
        As the arguments of :func:`equal_games`.
    computed : ndarray, shape (K, ...)
        The game's values (unary rows (K, A), or its pairwise table (K, A, K, A)).
    """

    rows: np.ndarray
    mask: np.ndarray
    computed: np.ndarray

    def match(self, rows, mask) -> EqualGames | None:
        """:func:`equal_games` of this game followed by a batch's games (game 0 is this
        one, game ``1 + b`` the batch's game b); None when the batch's K differs, or when no
        game repeats another."""
        if np.shape(mask)[1:] != self.mask.shape[1:]:
            return None
        return equal_games(*self.joined(rows, mask))

    def joined(self, rows, mask) -> tuple[np.ndarray, np.ndarray]:
        """``(rows, mask)`` of this game followed by a batch's games."""
        return np.concatenate([self.rows, rows]), np.concatenate([self.mask, mask])

    @staticmethod
    def largest(same: EqualGames, rows, mask, computed, first: int = 0):
        """The game of the largest group among the games ``first`` onwards of ``same``
        (groups of at least two), as a :class:`CarriedGame` whose ``computed`` is
        ``computed(g)`` for that game g; None when every game is alone. ``rows`` and
        ``mask`` are those ``same`` was found from."""
        k = same.source.shape[1]
        src = same.source[first:]
        group = np.maximum(src, 0).max(axis=1) // k
        count = np.bincount(group, minlength=same.games.size)
        best = int(np.argmax(count))
        if count[best] < 2:
            return None
        g = int(same.games[best])
        return CarriedGame(
            rows=np.asarray(rows)[g : g + 1].copy(),
            mask=np.asarray(mask)[g : g + 1].copy(),
            computed=np.array(computed(g), copy=True),
        )
