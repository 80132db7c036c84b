"""Equal games from the row index: the games that hold the same rows, up to order.

The reference is the definition: two games are equal when their sets of valid rows are
equal (np.unique over the sorted rows), and a repeated game takes every variable's values
from the variable of its group's first game that holds the same row.
"""

from __future__ import annotations

import numpy as np

from swarmgames.game import equal
from swarmgames.game.equal import CarriedGame, equal_games


def test_games_with_other_rows_are_not_shared():
    rows = np.array([[1, 2, -1], [2, 1, -1], [1, 2, 3], [1, 3, -1]])
    mask = rows >= 0
    d = equal_games(rows, mask)
    assert d.games.tolist() == [0, 2, 3]  # game 1 is game 0 in another order
    assert d.source[1].tolist() == [1, 0, -1]
    rows[1, 0] = 4  # robot 2 seen elsewhere in game 1: another row, another game
    assert equal_games(rows, mask) is None


def test_padding_rows_do_not_count():
    rows = np.array([[1, 2, 9], [2, 1, 7]])
    mask = np.array([[True, True, False], [True, True, False]])
    d = equal_games(rows, mask)
    assert d.games.tolist() == [0] and d.source.tolist() == [[0, 1, -1], [1, 0, -1]]


def test_random_batches_match_the_definition():
    rng = np.random.default_rng(3)
    for _ in range(30):
        b, k = rng.integers(2, 9), rng.integers(1, 6)
        rows = np.stack([rng.permutation(6)[:k] for _ in range(b)])
        mask = rng.random((b, k)) < 0.8
        d = equal_games(rows, mask)
        sets = [tuple(sorted(r[m])) for r, m in zip(rows, mask, strict=True)]
        firsts = sorted({s: i for i, s in reversed(list(enumerate(sets)))}.values())
        if len(firsts) == b:
            assert d is None
            continue
        assert d.games.tolist() == firsts
        src = d.source
        for g in range(b):
            for v in np.flatnonzero(mask[g]):
                r, kk = divmod(int(src[g, v]), k)
                assert rows[d.games[r], kk] == rows[g, v] and mask[d.games[r], kk]
        values = rng.random((len(firsts), k))
        expanded = d.expand(values)
        assert np.array_equal(expanded[~mask], np.zeros((~mask).sum()))


def test_repeated_rows_checks_equal_hashes_on_the_rows(monkeypatch):
    rows = np.array([[-1, 1, 3], [-1, 2, 2], [-1, 1, 3]])
    assert equal._repeated_rows(rows) and not equal._repeated_rows(rows[:2])
    # Every weight 1 (the multiplier 0, then the odd bit): the hash is the plain sum, equal
    # for the first two rows, so the rows themselves decide.
    monkeypatch.setattr(equal, "_COLUMN_MIX", np.uint64(0))
    assert equal._repeated_rows(rows) and not equal._repeated_rows(rows[:2])


def test_a_carried_game_matches_the_next_batch_by_rows():
    rows = np.array([[4, 5, 6], [6, 5, 4], [6, 5, 4]])
    mask = np.ones_like(rows, dtype=bool)
    d = equal_games(rows, mask)
    carried = CarriedGame.largest(d, rows, mask, lambda g: np.full((3, 2), float(g)))
    assert carried.rows.tolist() == [[4, 5, 6]] and carried.computed[0, 0] == 0.0
    nxt = np.array([[5, 6, 4], [1, 2, 3]])
    same = carried.match(nxt, np.ones_like(nxt, dtype=bool))
    assert same.games.tolist() == [0, 2]  # game 1 of ``same`` (batch game 0) is carried
    assert carried.match(nxt[:, :2], np.ones((2, 2), dtype=bool)) is None  # another K
