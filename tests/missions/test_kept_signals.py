"""The table of states' action signals kept across calls of the fused kernel: whatever it
holds, every call's unary is the one computed without it, bit for bit."""

import numpy as np
import pytest

from swarmgames.game.kept import KeptRows
from swarmgames.missions.coverage.kernel import compiled_windowed_unary
from tests.missions.test_kernel import MODEL, RASTER, SIGNAL


def _batch(rng, members, positions, k=6, b=12):
    """b games of k members each drawn from ``members`` (ids 2 m: real robots), each at its
    robot's position."""
    ids = np.stack([rng.choice(members, k, replace=False) for _ in range(b)])
    states = np.c_[positions[ids.reshape(-1)], np.full(ids.size, 30.0)].reshape(b, k, 3)
    mask = np.ones((b, k), dtype=bool)
    mask[:, 1:] = rng.random((b, k - 1)) < 0.85
    nxt = MODEL.apply(states)
    amask = MODEL.valid(states) & mask[..., None]
    return (mask, amask, states, nxt), 2 * ids


@pytest.mark.parametrize("max_elems", [1, 60_000, 10**8])
def test_kept_signals_give_the_unary_without_them(max_elems):
    rng = np.random.default_rng(4)
    positions = rng.uniform(-250.0, 250.0, (40, 2))
    signals = KeptRows(max_elems)
    for call in range(6):
        if call == 3:  # the robots move: their old entries must not be used
            positions[::2] += 7.0
        arrays, ids = _batch(rng, np.arange(40), positions)
        args = (RASTER, SIGNAL, -100.0, *arrays)
        want = compiled_windowed_unary(*args, softness_db=1.0, state_ids=ids)
        got = compiled_windowed_unary(
            *args, softness_db=1.0, state_ids=ids, signals=signals, chunk_elems=10**4
        )
        assert np.array_equal(got, want)
    # Repeated robots were found in the table rather than computed again (a table of at
    # least one chunk's states, however small the bound).
    assert signals.found > 0 and signals.computed > 0


def test_kept_signals_follow_a_new_window_and_owner_rows():
    rng = np.random.default_rng(8)
    positions = rng.uniform(-200.0, 200.0, (30, 2))
    arrays, ids = _batch(rng, np.arange(30), positions)
    signals = KeptRows()
    tables = []
    for floor, tau in ((-100.0, 1.0), (-95.0, 1.0), (-100.0, 0.0), (-100.0, 1.0)):
        args = (RASTER, SIGNAL, floor, *arrays)
        want = compiled_windowed_unary(*args, softness_db=tau, state_ids=ids)
        got = compiled_windowed_unary(*args, softness_db=tau, state_ids=ids, signals=signals)
        assert np.array_equal(got, want)
        tables.append(signals.table)
    # Each new window emptied the table and reused its memory (no new table to fill).
    assert len({t.shape for t in tables}) > 1
    assert all(np.shares_memory(tables[0], t) for t in tables[1:])
    owners = np.zeros(arrays[0].shape, dtype=bool)
    owners[:, 0] = True
    args = (RASTER, SIGNAL, -100.0, *arrays)
    want = compiled_windowed_unary(*args, softness_db=1.0, state_ids=ids, rows=owners)
    got = compiled_windowed_unary(
        *args, softness_db=1.0, state_ids=ids, rows=owners, signals=signals
    )
    assert np.array_equal(got, want)


def test_beliefs_that_differ_under_one_id_are_kept_apart():
    # Game 1 sees robot 2 elsewhere (an older message) under the same id.
    rng = np.random.default_rng(5)
    positions = rng.uniform(-150.0, 150.0, (12, 2))
    (mask, amask, states, nxt), ids = _batch(rng, np.arange(12), positions, k=4, b=6)
    states[1], nxt[1], mask[1], amask[1], ids[1] = states[0], nxt[0], mask[0], amask[0], ids[0]
    mask[:, 2] = True
    states[1, 2, :2] += 15.0
    nxt[1, 2] = MODEL.apply(states[1, 2][None])[0]
    amask[:, 2] = MODEL.valid(states[:, 2])
    args = (RASTER, SIGNAL, -100.0, mask, amask, states, nxt)
    want = compiled_windowed_unary(*args, softness_db=1.0)
    signals = KeptRows()
    for _ in range(2):
        got = compiled_windowed_unary(*args, softness_db=1.0, state_ids=ids, signals=signals)
        assert np.array_equal(got, want)


def test_a_state_used_again_keeps_its_row_over_one_used_once():
    # Three rows of one value each. The clock hand passes over a row used since it last came
    # by (its state was found again) and takes the first row that was not.
    signals = KeptRows(3)
    signals.prepare(("window",), 1, 1, 1, 10, 1)

    def assign(*ids):
        keys = np.asarray(ids, dtype=float)[:, None]
        rows, miss = signals.assign(np.asarray(ids), keys)
        return rows.tolist(), miss.tolist()

    assert assign(0, 1, 2) == ([0, 1, 2], [True, True, True])
    assert assign(0) == ([0], [False])  # found again
    assert assign(3) == ([1], [True])  # 1, used once, goes; 0 stays
    assert assign(0, 2, 3) == ([0, 2, 1], [False, False, False])
    # Every row was used since the hand last passed: it clears them and takes the next one
    # that the current chunk does not hold.
    assert assign(1, 0) == ([2, 0], [True, False])
    assert (signals.computed, signals.found) == (5, 5)


@pytest.mark.parametrize("bad", [0, -3, 2.5, True])
def test_kept_rows_reject_a_bad_bound(bad):
    with pytest.raises(ValueError, match="max_elems"):
        KeptRows(bad)


def test_the_stage_rows_give_the_signals_the_values_give():
    # Computing each stage row's signals once from the index alone gives the bits of
    # comparing the rows' values.
    from swarmgames.config.scaling import scaled_config
    from swarmgames.game import local_games
    from swarmgames.game.rows import row_ids
    from swarmgames.sim.runner import build_mission
    from tests.game.helpers import disk_snapshot

    mission = build_mission(scaled_config(60))
    pos = np.random.default_rng(2).uniform(-1000, 1000, size=(60, 2))
    pos = np.c_[pos, np.full(60, 30.0)]
    batch = local_games(disk_snapshot(pos[:, :2], 368.84), 2, pos, mission.action_model)
    arrays = (batch.mask, batch.action_mask, batch.states, batch.next_states)
    args = (RASTER, SIGNAL, -100.0, *arrays)
    ids = row_ids(batch.members, batch.is_virtual)
    by_values = compiled_windowed_unary(*args, softness_db=1.0, state_ids=ids)
    by_rows = compiled_windowed_unary(*args, softness_db=1.0, state_ids=ids,
                                      row_index=batch.rows)  # fmt: skip
    assert np.array_equal(by_rows, by_values)
