"""Tests of the virtual mean neighbours (paper eq. 3, section II.C, Algorithm 1 line 3) and of
the other variants of ``virtual_mean``: the mean over N_j − N_i only, the exact context and
none."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from swarmgames.game import (
    DisplacementActions,
    broadcast,
    build_local_game,
    build_local_games,
    gather_views,
    local_games,
    neighbourhood_means,
    outside_means,
    reaches_outside,
    receive,
    virtual_mode,
)
from swarmgames.network import TopologySnapshot
from tests.game.helpers import disk_snapshot


def _line(n: int) -> TopologySnapshot:
    idx = np.arange(n)
    return TopologySnapshot.from_hop_matrix(0.0, np.abs(idx[:, None] - idx[None, :]))


def test_virtual_mean_matches_eq3_on_a_hand_built_line():
    # Line 0-1-2-3-4, h = 1. Robot 1's local game: N_1 = {0, 1, 2}. N_0 = {0, 1} ⊆ N_1 stays
    # real; N_2 = {1, 2, 3} reaches robot 3 outside N_1, so robot 2 becomes the virtual mean
    # S̄_2 = (S_1 + S_2 + S_3) / 3 (eq. 3).
    states = np.array([[0.0, 0.0], [10.0, 1.0], [20.0, 4.0], [35.0, 7.0], [50.0, 9.0]])
    batch = local_games(_line(5), 1, states, DisplacementActions.headings(1.0, 4), owners=[1])
    assert batch.members[0].tolist() == [1, 0, 2]
    assert batch.is_virtual[0].tolist() == [False, False, True]
    np.testing.assert_allclose(batch.states[0, 0], states[1])
    np.testing.assert_allclose(batch.states[0, 1], states[0])
    np.testing.assert_allclose(batch.states[0, 2], (states[1] + states[2] + states[3]) / 3)
    # The actions of the virtual robot move its virtual state.
    np.testing.assert_allclose(batch.next_states[0, 2, 1], batch.states[0, 2] + [1.0, 0.0])


def test_virtual_mean_switched_off_keeps_reported_states():
    states = np.arange(10.0).reshape(5, 2)
    model = DisplacementActions.headings(1.0, 4)
    batch = local_games(_line(5), 1, states, model, owners=[1], virtual_mean=False)
    assert not batch.is_virtual.any()
    np.testing.assert_allclose(batch.states[0], states[[1, 0, 2]])


def test_h2_on_a_line_virtualises_only_the_far_members():
    # h = 2 (paper): N_2 = {0..4} on a line of 6; N_4 = {2..5} reaches 5; N_3 = {1..5} too;
    # N_0 = {0, 1, 2} and N_1 = {0..3} stay inside.
    batch = local_games(
        _line(6), 2, np.zeros((6, 2)), DisplacementActions.headings(1.0, 4), owners=[2]
    )
    virt = dict(zip(batch.members[0].tolist(), batch.is_virtual[0].tolist(), strict=True))
    assert virt == {2: False, 0: False, 1: False, 3: True, 4: True}


def test_neighbourhood_means_requires_non_empty_rows():
    a = sp.csr_array(np.array([[1, 0], [0, 0]], dtype=bool))
    with pytest.raises(ValueError, match="robot 1 has an empty one"):
        neighbourhood_means(a, np.zeros((2, 1)))


def test_reaches_outside_ignores_padding():
    members = np.array([[0, 1, -1]])
    mask = members >= 0
    nbh = np.array([[[0, 1, -1], [0, 1, 5], [7, 8, 9]]])
    assert reaches_outside(members, mask, nbh).tolist() == [[False, True, False]]


# --------------------------------------------------------------------------- the variants


def test_outside_mean_on_a_hand_built_line():
    # Line 0-1-2-3-4, h = 1, robot 1's game N_1 = {0, 1, 2}: N_2 = {1, 2, 3} reaches 3, so
    # robot 2 becomes a virtual robot at the mean of N_2 − N_1 = {3}: S_3 itself; robot 0
    # (N_0 ⊆ N_1) keeps its state, as in eq. 3 (paper section II.C).
    states = np.array([[0.0, 0.0], [10.0, 1.0], [20.0, 4.0], [35.0, 7.0], [50.0, 9.0]])
    model = DisplacementActions.headings(1.0, 4)
    batch = local_games(_line(5), 1, states, model, owners=[1], virtual_mean="outside")
    assert batch.is_virtual[0].tolist() == [False, False, True]
    np.testing.assert_allclose(batch.states[0], states[[1, 0, 3]], rtol=0, atol=1e-12)
    # h = 2 on a line of 7, robot 3: N_3 = {1..5}; N_1 = {0..3} and N_2 = {0..4} reach {0},
    # N_4 = {2..6} and N_5 = {3..6} reach {6}: S̄_1^out = S̄_2^out = S_0, S̄_4^out = S̄_5^out = S_6.
    states = np.arange(14.0).reshape(7, 2) ** 1.5
    batch = local_games(_line(7), 2, states, model, owners=[3], virtual_mean="outside")
    assert batch.members[0].tolist() == [3, 1, 2, 4, 5]
    assert batch.is_virtual[0].tolist() == [False, True, True, True, True]
    np.testing.assert_allclose(batch.states[0], states[[3, 0, 0, 6, 6]], rtol=1e-12)


@pytest.mark.parametrize(("alias", "name"), [(True, "eq3"), (False, "off")])
def test_boolean_switch_names_eq3_and_off_bit_for_bit(alias, name):
    rng = np.random.default_rng(3)
    pos = rng.uniform(0, 300, (30, 2))
    snap = disk_snapshot(pos, 90.0)
    model = DisplacementActions.headings(5.0, 8)
    a = local_games(snap, 2, pos, model, virtual_mean=alias)
    b = local_games(snap, 2, pos, model, virtual_mean=name)
    for field in ("members", "mask", "states", "is_virtual", "next_states", "action_mask"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
    assert a.is_context is None and b.is_context is None


def test_eq3_is_the_mean_over_n_j_with_j_and_i_included():
    # Eq. 3 as the paper writes it, computed here from the snapshot and the swarm's states:
    # every virtual member sits at the mean of the states of its whole N_j.
    rng = np.random.default_rng(5)
    pos = rng.uniform(0, 300, (25, 2))
    snap = disk_snapshot(pos, 90.0)
    batch = local_games(snap, 2, pos, DisplacementActions.headings(5.0, 8), virtual_mean="eq3")
    for i in range(25):
        members = batch.members[i][batch.mask[i]]
        for c, j in enumerate(members):
            nj = snap.neighbourhood(int(j), 2)
            want = pos[nj].mean(axis=0) if set(nj) - set(members) else pos[j]
            np.testing.assert_allclose(batch.states[i, c], want, rtol=1e-12)
            assert batch.is_virtual[i, c] == bool(set(nj) - set(members))


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 30), h=st.integers(1, 3))
def test_outside_mean_against_the_sets_on_random_topologies(seed, n, h):
    # S̄_j^out = mean of S_k over k ∈ N_j − N_i: the batched builder against the per-robot
    # set-based one, and both against the mean computed from the swarm's states directly.
    rng = np.random.default_rng(seed)
    pos = rng.uniform(0.0, 300.0, size=(n, 2))
    snap = disk_snapshot(pos, float(rng.uniform(40.0, 150.0)))
    model = DisplacementActions.headings(5.0, 8)
    msgs = broadcast(snap, h, pos)
    batch = build_local_games(gather_views(msgs), model, virtual_mean="outside")
    for i in range(n):
        one = build_local_game(receive(msgs, i), model, virtual_mean="outside")
        k = one.n_vars
        np.testing.assert_array_equal(batch.is_virtual[i, :k], one.is_virtual[0])
        np.testing.assert_allclose(batch.states[i, :k], one.states[0], rtol=1e-12, atol=1e-9)
        inside = set(snap.neighbourhood(i, h).tolist())
        for c, j in enumerate(one.members[0]):
            out = sorted(set(snap.neighbourhood(int(j), h).tolist()) - inside)
            want = pos[out].mean(axis=0) if out else pos[j]
            assert one.is_virtual[0, c] == bool(out)
            np.testing.assert_allclose(one.states[0, c], want, rtol=1e-12, atol=1e-9)


def test_outside_means_of_members_that_stay_inside_are_their_eq3_means():
    members = np.array([[0, 1]])
    nbh = np.array([[[0, 1], [0, 1]]])
    mean = np.array([[[0.5], [0.5]]])
    out = outside_means(members, members >= 0, np.array([[[0.0], [1.0]]]), mean, nbh)
    np.testing.assert_array_equal(out, mean)


@pytest.mark.parametrize("bad", [1, 0, "EQ3", "true", None, 2.0])
def test_virtual_mode_rejects_anything_else(bad):
    with pytest.raises(ValueError, match=r"virtual_mean must be one of 'eq3', 'outside'"):
        virtual_mode(bad)


# --------------------------------------------------------------------------- exact context


def _grid(side: int) -> TopologySnapshot:
    # 4-neighbour grid, robot r at (r // side, r % side); hops = Manhattan distance.
    r = np.arange(side * side)
    rc = np.c_[r // side, r % side]
    return TopologySnapshot.from_hop_matrix(0.0, np.abs(rc[:, None] - rc[None]).sum(axis=2))


def test_exact_context_on_a_line_worked_by_hand():
    # Line 0-...-6, h = 1, robot 2: N_2 = {1, 2, 3}; N_1 = {0, 1, 2} and N_3 = {2, 3, 4}, so
    # the context ∪_j N_j − N_2 is {0, 4}: robots 0 and 4 join the game at their reported
    # states with a single action that keeps them there; nobody is a virtual mean.
    states = np.c_[np.arange(7) * 10.0, np.arange(7) ** 2.0]
    model = DisplacementActions.headings(1.0, 4)  # action 0 is "stay"
    batch = local_games(_line(7), 1, states, model, owners=[2], virtual_mean="exact")
    assert batch.members[0].tolist() == [2, 1, 3, 0, 4]
    assert batch.is_context[0].tolist() == [False, False, False, True, True]
    assert batch.players[0].tolist() == [True, True, True, False, False]
    assert not batch.is_virtual.any()
    np.testing.assert_array_equal(batch.states[0], states[[2, 1, 3, 0, 4]])
    assert batch.action_mask[0, 3].tolist() == [True, False, False, False, False]
    np.testing.assert_array_equal(batch.next_states[0, 3], np.repeat(states[[0]], 5, axis=0))
    # h = 2 on the same line, robot 0: N_0 = {0, 1, 2}, N_2 = {0..4}: context {3, 4}.
    batch = local_games(_line(7), 2, states, model, owners=[0], virtual_mean="exact")
    assert batch.members[0].tolist() == [0, 1, 2, 3, 4]
    assert batch.is_context[0].tolist() == [False, False, False, True, True]


def test_exact_context_on_a_grid_worked_by_hand():
    # 3 x 3 grid, h = 1. The centre 4 sees {1, 3, 5, 7}; their neighbours add the corners
    # {0, 2, 6, 8}. The corner 0 sees {1, 3}; N_1 = {0, 1, 2, 4}, N_3 = {0, 3, 4, 6}: context
    # {2, 4, 6}; the far corner 8 is three hops away and stays out.
    states = np.c_[np.arange(9.0), -np.arange(9.0)]
    model = DisplacementActions.headings(1.0, 4)
    batch = local_games(_grid(3), 1, states, model, owners=[4, 0], virtual_mean="exact")
    got = {
        int(batch.owner[b]): (
            batch.members[b][batch.players[b]].tolist(),
            batch.members[b][batch.is_context[b]].tolist(),
        )
        for b in range(2)
    }
    assert got == {4: ([4, 1, 3, 5, 7], [0, 2, 6, 8]), 0: ([0, 1, 3], [2, 4, 6])}
    np.testing.assert_array_equal(batch.states[1, :6], states[[0, 1, 3, 2, 4, 6]])


def test_exact_needs_views_with_context():
    msgs = broadcast(_line(4), 1, np.zeros((4, 2)))
    with pytest.raises(ValueError, match="needs the states of every game's context"):
        build_local_games(
            gather_views(msgs), DisplacementActions.headings(1.0, 4), virtual_mean="exact"
        )


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 30), h=st.integers(1, 2))
def test_exact_context_against_the_sets_on_random_topologies(seed, n, h):
    # The batched builder against the per-robot set-based one (bit for bit), and the context
    # against ∪_{j ∈ N_i} N_j − N_i computed from the routing tables.
    rng = np.random.default_rng(seed)
    pos = rng.uniform(0.0, 300.0, size=(n, 2))
    snap = disk_snapshot(pos, float(rng.uniform(40.0, 150.0)))
    model = DisplacementActions.headings(5.0, 8, lower=[0.0, 0.0], upper=[300.0, 300.0])
    msgs = broadcast(snap, h, pos)
    batch = build_local_games(gather_views(msgs, context=True), model, virtual_mean="exact")
    np.testing.assert_array_equal(batch.mask.sum(axis=1), msgs.sizes + msgs.context_sizes)
    for i in range(n):
        one = build_local_game(receive(msgs, i, context=True), model, virtual_mean="exact")
        k = one.n_vars
        for field in ("members", "is_context", "states", "next_states", "action_mask"):
            np.testing.assert_array_equal(getattr(batch, field)[i, :k], getattr(one, field)[0])
        assert not batch.mask[i, k:].any()
        inside = set(snap.neighbourhood(i, h).tolist())
        ctx = set().union(*(set(snap.neighbourhood(int(j), h).tolist()) for j in inside)) - inside
        assert set(one.members[0][one.is_context[0]].tolist()) == ctx
        np.testing.assert_array_equal(one.states[0], pos[one.members[0]])
        # Context robots have one action, which leaves them where they are.
        assert (one.action_mask[0][one.is_context[0]].sum(axis=1) == 1).all()


@pytest.mark.parametrize("seed", range(6))
def test_member_columns_match_a_search_per_entry(seed):
    # The compiled lookup against the definition: the first column of the game holding
    # that robot, -1 for a robot outside the game and for padding.
    from swarmgames.game.virtual import member_columns

    rng = np.random.default_rng(seed)
    b, k, width, n = 17, 9, 13, 40
    members = np.full((b, k), -1)
    for g in range(b):
        m = rng.integers(1, k + 1)
        members[g, :m] = rng.choice(n, size=m, replace=False)
    mask = members >= 0
    nbh = np.where(rng.random((b, k, width)) < 0.7, rng.integers(0, n + 5, (b, k, width)), -1)
    got = member_columns(members, mask, nbh)
    for g, j, e in np.ndindex(b, k, width):
        cols = [c for c in range(k) if mask[g, c] and members[g, c] == nbh[g, j, e]]
        assert got[g, j, e] == (cols[0] if cols and nbh[g, j, e] >= 0 else -1)
