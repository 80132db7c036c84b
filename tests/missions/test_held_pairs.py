"""Equal float64 games of a batch share one held table (swarmgames.game.held.HeldPairs).

The reference is the held path, a table per game (``pair_table``, each repeated game a
reordered copy of its group's): the source must give the same W, bit for bit, through every
method of the PairSource protocol (docs/game.md), and the compiled mean-field engine the
same results for each group's first game and, for the others (whose pair fields it sums in
the first game's order), the same up to float64 rounding.
"""

from __future__ import annotations

import numpy as np
import pytest

from swarmgames.game import held, mean_field
from swarmgames.game.held import HELD_SHARE_MIN, HeldPairs
from swarmgames.game.potentials import evaluate_payoffs
from swarmgames.game.rows import StageRows
from tests.missions.test_equal_games import _dense, _moved


def _payoffs(batch, pot, share: bool, monkeypatch):
    monkeypatch.setattr(held, "HELD_SHARE_MIN", HELD_SHARE_MIN if share else 10**9)
    # Each computation on its own: a stage of its own, with no carried table.
    return evaluate_payoffs(batch.on(StageRows()), pot, 1.0, 0.001, dtype=np.float64)


@pytest.mark.parametrize("moved", [False, True])
def test_a_held_group_table_gives_every_game_its_own_table_bit_for_bit(monkeypatch, moved):
    batch, pot = _dense(120, None, "auto")  # 120 robots x 9 actions >= HELD_SHARE_MIN
    batch = batch.select([0, 5, 17, 60, 119])
    if moved:
        batch = _moved(batch, 3)  # game 3 no longer equals the others
    own = _payoffs(batch, pot, False, monkeypatch)
    shared = _payoffs(batch, pot, True, monkeypatch)
    src = shared.pair_source
    assert own.pair_source is None and isinstance(src, HeldPairs)
    assert src.tables.shape[0] == (2 if moved else 1)  # one table per group
    assert np.array_equal(shared.unary, own.unary)
    assert np.array_equal(src.table(np.arange(5)), own.pair)
    rng = np.random.default_rng(1)
    x = np.argmax(np.where(own.action_mask, rng.random(own.action_mask.shape), -1), axis=2)
    assert np.array_equal(shared.pair_at(x), own.pair_at(x))
    # shared(): every game's table in rank order is its head's ranked table.
    head, rank = src.shared()
    ranked = src.ranked_table(np.unique(head))
    slot = {int(h): i for i, h in enumerate(np.unique(head))}
    for b in range(5):
        t = ranked[slot[int(head[b])]]
        r = rank[b]
        assert np.array_equal(t[r][:, :, r], own.pair[b])
    sub = src.select([4, 1])
    assert np.array_equal(sub.table(np.arange(2)), own.pair[[4, 1]])
    assert np.array_equal(sub.at(x[[4, 1]]), own.pair_at(x)[[4, 1]])
    # The engine: each group's first game exactly as on its own table, the others to rounding.
    a, b = mean_field(own, 50.0), mean_field(shared, 50.0)
    first = np.unique(head)
    assert np.array_equal(a.marginals[first], b.marginals[first])
    np.testing.assert_allclose(b.marginals, a.marginals, rtol=0, atol=1e-12)
    assert np.array_equal(a.marginals.argmax(axis=2), b.marginals.argmax(axis=2))


def test_small_games_keep_their_own_tables(monkeypatch):
    batch, pot = _dense(9, None, "auto")  # the golden runs' size: 81 entries per game
    assert batch.n_vars * batch.n_actions < HELD_SHARE_MIN
    assert _payoffs(batch, pot, True, monkeypatch).pair_source is None
