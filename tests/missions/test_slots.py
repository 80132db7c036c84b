"""shared_rows against its definition: numpy's sorted unique of the ids, then a slot of its
own for every row whose values differ from its id's first row."""

import numpy as np
import pytest

from swarmgames.missions.coverage.slots import shared_rows


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
