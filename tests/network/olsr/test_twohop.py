"""The 2-hop set's compiled passes against their definitions (RFC 3626 sections 8.2.1, 8.3.1
and 10): a HELLO round's new tuples, and the strict 2-hop neighbourhood."""

import numpy as np
import pytest

from swarmgames.network.olsr import twohop
from swarmgames.network.olsr.routing import compute_routes
from swarmgames.network.olsr.twohop import round_tuples, strict_two_hop


def _sym_links(rng, n, p):
    """Random symmetric links as sorted keys ``r * n + j`` (no self-links)."""
    adj = rng.random((n, n)) < p
    adj = adj | adj.T
    np.fill_diagonal(adj, False)
    r, j = np.nonzero(adj)
    return r.astype(np.int64) * n + j


@pytest.mark.parametrize("seed", range(6))
def test_round_tuples_are_every_listed_neighbour_but_the_receiver(seed):
    """RFC 3626 8.2.1: a HELLO from symmetric neighbour j gives r a tuple (r, j, x) for every
    symmetric neighbour x that j lists, except r itself; the keys come out sorted."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 40))
    listed = _sym_links(rng, n, rng.uniform(0.05, 0.9))
    ptr = np.searchsorted(listed, np.arange(n + 1) * n)
    pairs = rng.permutation(_sym_links(rng, n, rng.uniform(0.05, 0.9)))  # any order
    pairs = pairs[: rng.integers(0, pairs.size + 1)]
    r, j = pairs // n, pairs % n
    expiry_of = rng.uniform(0, 10, n)
    keys, expiry = round_tuples(r, j, listed, ptr, expiry_of, n)
    want = [
        ((ri * n + ji) * n + x, expiry_of[ji])
        for ri, ji in zip(r.tolist(), j.tolist(), strict=True)
        for x in (listed[ptr[ji] : ptr[ji + 1]] - ji * n).tolist()
        if x != ri
    ]
    want.sort()
    assert keys.tolist() == [k for k, _ in want]
    np.testing.assert_array_equal(expiry, np.array([e for _, e in want], dtype=float))
    assert keys.dtype == np.int64 and expiry.dtype == np.float64


def test_round_tuples_of_no_pairs_or_empty_lists():
    n = 3
    none = np.array([], np.int64)
    keys, expiry = round_tuples(none, none, np.array([3, 5]), np.array([0, 0, 2, 2]),
                                np.zeros(n), n)  # fmt: skip
    assert keys.size == 0 and expiry.size == 0
    # Node 1 lists only node 0, which hears it: nothing to add.
    keys, _ = round_tuples(np.array([0]), np.array([1]), np.array([3]),
                           np.array([0, 0, 1, 1]), np.zeros(n), n)  # fmt: skip
    assert keys.size == 0


def _split(keys, n):
    return keys // (n * n), keys // n % n, keys % n


def _strict_reference(keys, expiry, clock, sym_keys, n):
    owner, neigh, x = _split(keys, n)
    ok = expiry > clock[owner]
    ok &= np.isin(owner * n + neigh, sym_keys)
    ok &= (x != owner) & ~np.isin(owner * n + x, sym_keys)
    return owner[ok], neigh[ok], x[ok]


@pytest.mark.parametrize("buffer", [1, twohop.STRICT_BUFFER])
@pytest.mark.parametrize("seed", range(8))
def test_strict_two_hop_is_the_rfc_filter(seed, buffer, monkeypatch):
    """RFC 3626 8.3.1 and 10: valid tuples whose relay is a symmetric neighbour and whose
    target is neither the owner nor a symmetric neighbour, in the table's order (in one
    pass, or in two when the first one's buffer is too small)."""
    monkeypatch.setattr(twohop, "STRICT_BUFFER", buffer)
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 30))
    keys = np.unique(rng.integers(0, n**3, int(rng.integers(0, 4 * n**2 + 1))))
    expiry = rng.uniform(0, 10, keys.size)
    expiry[rng.random(keys.size) < 0.05] = np.nan  # never valid
    clock = rng.uniform(0, 10, n)
    clock[rng.random(n) < 0.2] = -np.inf  # every tuple of these owners valid
    sym_keys = _sym_links(rng, n, rng.uniform(0.0, 0.8))
    got = strict_two_hop(keys, expiry, clock, sym_keys, n)
    want = _strict_reference(keys, expiry, clock, sym_keys, n)
    for g, w in zip(got, want, strict=True):
        assert g.dtype == np.int32
        np.testing.assert_array_equal(g, w)


def test_strict_two_hop_of_a_clique_is_empty():
    """Every robot within range of every other: each 2-hop target is a neighbour."""
    n = 12
    o, j, x = np.meshgrid(np.arange(n), np.arange(n), np.arange(n), indexing="ij")
    keep = (o != j) & (j != x)
    keys = ((o * n + j) * n + x)[keep]
    sym_keys = _sym_links(np.random.default_rng(0), n, 1.1)
    got = strict_two_hop(keys, np.full(keys.size, 5.0), np.zeros(n), sym_keys, n)
    assert all(a.size == 0 for a in got)
    assert strict_two_hop(keys[:0], keys[:0] * 1.0, np.zeros(n), sym_keys, n)[0].size == 0


@pytest.mark.parametrize("seed", range(4))
def test_routes_from_strict_tuples_are_the_routes_from_all_tuples(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 25))
    sym_keys = _sym_links(rng, n, rng.uniform(0.05, 0.5))
    keys = np.unique(rng.integers(0, n**3, 3 * n**2))
    owner, neigh, x = _split(keys, n)
    s_owner, s_neigh = sym_keys // n, sym_keys % n
    strict = strict_two_hop(keys, np.ones(keys.size), np.zeros(n), sym_keys, n)
    whole = compute_routes(n, s_owner, s_neigh, owner, neigh, x)
    fast = compute_routes(n, s_owner, s_neigh, *strict, strict=True)
    for a, b in zip(whole, fast, strict=True):
        np.testing.assert_array_equal(a, b)
