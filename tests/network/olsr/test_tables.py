"""Keyed tables and key sets behind the OLSR information repositories."""

import numpy as np
import pytest

from swarmgames.network.olsr import tables
from swarmgames.network.olsr.tables import (
    KeyedTable,
    KeySet,
    first_per_key,
    live_at,
    sorted_contains,
)


def test_keyed_table_upsert_get_keep_drop():
    t = KeyedTable(("a", "b"))
    t.upsert(np.array([5, 1]), a=np.array([50.0, 10.0]))
    assert t.keys.tolist() == [1, 5]
    assert t.get("a", np.array([5, 1, 3])).tolist() == [50.0, 10.0, -np.inf]
    assert t.get("b", np.array([1])).tolist() == [-np.inf]  # column not given: -inf
    t.upsert(np.array([5, 7]), a=np.array([55.0, 70.0]), b=np.array([1.0, 2.0]))
    assert t.keys.tolist() == [1, 5, 7]
    assert t.cols["a"].tolist() == [10.0, 55.0, 70.0]
    assert t.cols["b"].tolist() == [-np.inf, 1.0, 2.0]
    t.drop_prefixes(np.array([0]), base=6)  # keys 1 and 5 have prefix 0
    assert t.keys.tolist() == [7]
    t.keep(np.array([False]))
    assert len(t) == 0


@pytest.mark.parametrize("limit", [0, 10**6])
def test_key_set_and_first_per_key_dense_and_sparse(monkeypatch, limit):
    # Two implementations that must agree: dense flags / claim arrays and sorted keys.
    monkeypatch.setattr(tables, "DENSE_LIMIT", limit)
    s = KeySet(100)
    assert s.dense == (limit > 0)
    assert not s.contains(np.array([3])).any()
    s.add(np.array([3, 9]))
    s.add(np.array([9, 50]))
    assert s.contains(np.array([3, 4, 9, 50, 99])).tolist() == [True, False, True, True, False]
    keys = np.array([4, 2, 4, 7, 2])
    assert sorted(first_per_key(keys, 100).tolist()) == [0, 1, 3]
    order = np.array([4, 3, 2, 1, 0])  # reversed: later occurrences come first
    assert sorted(first_per_key(keys, 100, order).tolist()) == [2, 3, 4]


def test_sorted_contains():
    assert sorted_contains(np.array([1, 4, 9]), np.array([0, 4, 10, 9])).tolist() == [
        False,
        True,
        False,
        True,
    ]
    assert not sorted_contains(np.zeros(0, np.int64), np.array([1])).any()


def test_upsert_of_sorted_new_keys_merges_them_as_the_general_path_does():
    rng = np.random.default_rng(3)
    keys = np.unique(rng.integers(0, 10_000, 400))
    old, new = keys[::2], keys[1::2]
    merged, general = KeyedTable(("a", "b")), KeyedTable(("a", "b"))
    for t in (merged, general):
        t.upsert(old, a=old * 1.0, b=-old * 1.0)
    merged.upsert(new, a=new + 0.5)  # sorted and all new: merged in
    general.upsert(new[::-1], a=new[::-1] + 0.5)  # unsorted: concatenated and sorted again
    np.testing.assert_array_equal(merged.keys, general.keys)
    for c in ("a", "b"):
        np.testing.assert_array_equal(merged.cols[c], general.cols[c])
    assert np.isneginf(merged.get("b", new)).all()


@pytest.mark.parametrize("span", [1_000, 50_000, 20_000_000])
def test_sorted_contains_dense_and_binary_search_agree(span):
    """The flag-array path (keys spanning at most DENSE_LIMIT values, a large query) and
    the binary search give the same mask, queries outside the keys' span included."""
    rng = np.random.default_rng(span)
    keys = np.unique(rng.integers(0, span, 500))
    query = rng.integers(-10, span + 10, 20_000)
    query[:3] = [keys[0], keys[-1], keys[-1] + 1]
    expect = np.isin(query, keys)
    assert np.array_equal(sorted_contains(keys, query), expect)
    assert np.array_equal(sorted_contains(keys, query[:5]), expect[:5])  # a small query


def test_many_sorted_lookups_walk_the_table_and_agree_with_a_search():
    rng = np.random.default_rng(3)
    t = KeyedTable(("expiry",))
    table_keys = np.unique(rng.integers(0, 10**9, 5_000))
    t.upsert(table_keys, expiry=1.0)
    query = np.sort(np.concatenate([rng.integers(-5, 10**9 + 5, 150_000), table_keys[::7]]))
    assert query.size > tables._WALK_MIN
    idx, found = t.find(query)
    assert np.array_equal(idx, np.searchsorted(table_keys, query))
    assert np.array_equal(found, np.isin(query, table_keys)) and found.sum() >= table_keys[::7].size
    # And the merge of as many new keys keeps the table sorted, with their values.
    new = np.setdiff1d(query, table_keys)
    t.upsert(new, expiry=np.arange(new.size, dtype=float))
    assert np.array_equal(t.keys, np.union1d(table_keys, new))
    assert np.array_equal(t.get("expiry", new), np.arange(new.size, dtype=float))
    assert np.all(t.get("expiry", table_keys) == 1.0)


@pytest.mark.parametrize("n", [1, 7, 300, 10_000])
@pytest.mark.parametrize("order", ["sorted", "shuffled"])
def test_owner_clocks_agree_with_integer_division(n, order):
    """The compiled walk divides once per run of equal prefixes; any order of keys (sorted
    as the tables keep them, or not) gives numpy's ``//`` exactly."""
    rng = np.random.default_rng(n)
    keys = np.unique(rng.integers(0, n**3, 20_000))
    keys = np.concatenate([[0, n**3 - 1], keys]) if n > 1 else np.zeros(3, np.int64)
    keys = np.sort(keys) if order == "sorted" else rng.permutation(keys)
    expiry = rng.uniform(0, 10, keys.size)
    clock = rng.uniform(0, 10, n)
    for base in (n, n * n):
        owner = keys // base
        sel = owner < n
        got = live_at(keys[sel], base, expiry[sel], clock)
        assert np.array_equal(got, expiry[sel] > clock[owner[sel]])
    empty = np.zeros(0, np.int64)
    assert live_at(empty, n, np.zeros(0), clock).size == 0
