"""shared_rows against its definition: numpy's sorted unique of the ids, then a slot of its
own for every row whose values differ from its id's first row."""

import numpy as np
import pytest

from swarmgames.game.rows import shared_rows


def _by_definition(ids, *values):
    _, first, slot = np.unique(ids, return_index=True, return_inverse=True)
    slot = slot.reshape(-1).astype(np.int64)
    ref = first[slot]
    same = np.ones(slot.size, dtype=bool)
    for v in values:
        same &= (v == v[ref]).reshape(slot.size, -1).all(axis=1)
    own = np.flatnonzero(~same)
    slot[own] = first.size + np.arange(own.size)
    return slot, np.concatenate([first, own]).astype(np.int64)


@pytest.mark.parametrize("seed", range(40))
def test_shared_rows_follows_its_definition(seed):
    rng = np.random.default_rng(seed)
    r = int(rng.integers(1, 80))
    # dense small ids (the direct-address table), or sparse ones (the sort)
    ids = rng.integers(-5, 30, r) if seed % 3 else rng.integers(0, 10**12, r)
    states = rng.integers(0, 2, (r, 3)).astype(float)
    if seed % 5 == 0:
        states[0, 0] = np.nan  # differs from itself: a slot of its own
    if seed % 7 == 0:
        states[:, 1] = np.where(rng.random(r) > 0.5, 0.0, -0.0)  # -0 equals 0
    valid = rng.random((r, 2, 2)) > 0.5
    got = shared_rows(ids, states, valid)
    want = _by_definition(ids, states, valid)
    assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])


def test_shared_rows_of_no_rows():
    slot, first = shared_rows(np.zeros(0, int), np.zeros((0, 3)))
    assert slot.size == 0 and first.size == 0


def _batch(states, members, is_virtual=None, stage=None):
    from swarmgames.game import DisplacementActions, LocalGameBatch

    model = DisplacementActions.headings(1.0, 4)
    members = np.asarray(members)
    states = np.asarray(states, dtype=float)
    virtual = np.zeros(members.shape, bool) if is_virtual is None else np.asarray(is_virtual)
    batch = LocalGameBatch(
        owner=members[:, 0], members=members, mask=members >= 0, states=states,
        is_virtual=virtual, next_states=model.apply(states),
        action_mask=np.ones((*members.shape, model.n_actions), dtype=bool),
    )  # fmt: skip
    return batch if stage is None else batch.on(stage)


def test_stage_rows_number_equal_rows_alike_across_batches():
    from swarmgames.game.rows import StageRows

    stage = StageRows()
    s = np.array([[[0.0, 0.0], [1.0, 0.0]], [[1.0, 0.0], [0.0, 0.0]]])
    first = _batch(s, [[0, 1], [1, 0]], stage=stage)
    assert first.rows.tolist() == [[0, 1], [1, 0]]
    # Robot 1 seen 0.5 m off in the second batch: a row of its own; robot 0 the same row.
    moved = np.array([[[1.5, 0.0], [0.0, 0.0]]])
    second = _batch(moved, [[1, 0]], stage=stage)
    assert second.rows.tolist() == [[2, 0]] and stage.n_rows == 3
    # The same robot as a virtual mean at the same state is another row.
    third = _batch(s[:1], [[0, 1]], is_virtual=[[False, True]], stage=stage)
    assert third.rows.tolist() == [[0, 3]]
    # select keeps the rows; a batch built alone numbers its own.
    assert first.select([1]).rows.tolist() == [[1, 0]]
    assert _batch(moved, [[1, 0]]).rows.tolist() == [[1, 0]]  # rows in the order of ids


def test_padding_and_nan_rows():
    from swarmgames.game.rows import StageRows

    stage = StageRows()
    s = np.array([[[0.0, 0.0], [np.nan, 0.0]], [[0.0, 0.0], [np.nan, 0.0]]])
    batch = _batch(s, [[0, 1], [0, 1]], stage=stage)
    rows = batch.rows
    assert rows[0, 0] == rows[1, 0] and rows[0, 1] != rows[1, 1]  # NaN equals nothing
    pad = _batch(np.zeros((1, 2, 2)), [[0, -1]], stage=stage)
    assert pad.rows.tolist() == [[rows[0, 0], -1]]


def test_the_stage_carries_a_value_to_its_next_batch_for_its_owner_alone():
    from swarmgames.game.rows import StageRows

    stage, one, other = StageRows(), object(), object()
    assert stage.carried(one, "x") is None
    stage.carry(one, "x", 3)
    assert stage.carried(one, "x") == 3 and stage.carried(other, "x") is None
    stage.carry(one, "x", None)
    assert stage.carried(one, "x") is None
