"""Tests of the local game decomposition (paper section II.C, Algorithm 1 lines 1-3)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from swarmgames.game import (
    DisplacementActions,
    LocalGameBatch,
    broadcast,
    build_local_game,
    build_local_games,
    centralised_game,
    gather_views,
    local_games,
    receive,
)
from swarmgames.network import TopologySnapshot
from tests.game.helpers import disk_snapshot

MODEL = DisplacementActions.headings(5.0, 8, lower=[0.0, 0.0], upper=[300.0, 300.0])


def _swarm(seed: int, n: int, radius: float = 90.0):
    rng = np.random.default_rng(seed)
    pos = rng.uniform(0.0, 300.0, size=(n, 2))
    return pos, disk_snapshot(pos, radius)


@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(1, 25),
    h=st.integers(1, 3),
    virtual=st.sampled_from([True, False, "eq3", "outside", "off"]),
)
def test_batched_builder_equals_per_robot_builder(seed, n, h, virtual):
    pos, snap = _swarm(seed, n)
    msgs = broadcast(snap, h, pos)
    batch = build_local_games(gather_views(msgs), MODEL, virtual_mean=virtual)
    # The outside mean sums the copies in another order per robot: equal to rounding.
    same = np.testing.assert_array_equal
    if virtual == "outside":
        same = lambda a, b: np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-9)  # noqa: E731
    for i in range(n):
        one = build_local_game(receive(msgs, i), MODEL, virtual_mean=virtual)
        k = one.n_vars
        np.testing.assert_array_equal(batch.members[i, :k], one.members[0])
        assert np.all(batch.members[i, k:] == -1) and not batch.mask[i, k:].any()
        np.testing.assert_array_equal(batch.is_virtual[i, :k], one.is_virtual[0])
        same(batch.states[i, :k], one.states[0])
        same(batch.next_states[i, :k], one.next_states[0])
        np.testing.assert_array_equal(batch.action_mask[i, :k], one.action_mask[0])
        # N_i(h) from the routing table (paper section II.A), owner first.
        assert sorted(one.members[0].tolist()) == snap.neighbourhood(i, h).tolist()
        assert one.members[0, 0] == i


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(2, 20),
    virtual=st.sampled_from([True, False, "outside", "exact"]),
)
def test_local_game_reads_only_local_information(seed, n, virtual):
    # Robot i's game may depend only on the states in N_i and, through the virtual means,
    # on the states in N_j for j in N_i. Moving every other robot changes nothing.
    h = 2
    pos, snap = _swarm(seed, n)
    rng = np.random.default_rng(seed + 1)
    for i in range(n):
        members = snap.neighbourhood(i, h)
        reach = set(members.tolist())
        if virtual is not False:
            for j in members:
                reach |= set(snap.neighbourhood(int(j), h).tolist())
        moved = pos.copy()
        far = np.array(sorted(set(range(n)) - reach), dtype=int)
        moved[far] += rng.normal(scale=50.0, size=(far.size, 2))
        a = local_games(snap, h, pos, MODEL, virtual_mean=virtual, owners=[i])
        b = local_games(snap, h, moved, MODEL, virtual_mean=virtual, owners=[i])
        np.testing.assert_array_equal(a.states, b.states)
        np.testing.assert_array_equal(a.next_states, b.next_states)


def test_isolated_robot_gets_a_one_variable_game():
    pos = np.array([[0.0, 0.0], [10.0, 0.0], [1000.0, 1000.0]])
    batch = local_games(disk_snapshot(pos, 50.0), 2, pos, DisplacementActions.headings(1.0, 4))
    assert batch.members[2].tolist() == [2, -1]
    assert batch.mask[2].tolist() == [True, False]
    assert not batch.is_virtual[2].any()
    assert not batch.action_mask[2, 1].any()


def test_single_robot_swarm():
    snap = TopologySnapshot.from_hop_matrix(0.0, np.zeros((1, 1)))
    batch = local_games(snap, 2, np.array([[3.0, 4.0]]), DisplacementActions.headings(1.0, 4))
    assert batch.members.tolist() == [[0]] and batch.n_actions == 5


def test_partitioned_swarm_games_stay_within_their_component():
    pos = np.array([[0.0, 0], [50, 0], [100, 0], [5000, 0], [5050, 0]])
    batch = local_games(disk_snapshot(pos, 60.0), 2, pos, DisplacementActions.headings(1.0, 4))
    assert set(batch.members[0][batch.mask[0]].tolist()) == {0, 1, 2}
    assert set(batch.members[3][batch.mask[3]].tolist()) == {3, 4}


def test_co_located_robots_are_handled():
    pos = np.zeros((4, 2))
    batch = local_games(disk_snapshot(pos, 1.0), 1, pos, DisplacementActions.headings(1.0, 4))
    assert batch.mask.all() and not batch.is_virtual.any()


def test_asymmetric_routing_tables_use_each_robot_own_view():
    # OLSR lag can leave j in i's table but not i in j's (docs/reference.md section 4).
    hops = np.array([[0, 1, 0], [0, 0, 1], [0, 1, 0]])  # 0 sees 1; 1 sees 2 only
    snap = TopologySnapshot.from_hop_matrix(0.0, hops)
    batch = local_games(snap, 1, np.zeros((3, 2)), DisplacementActions.headings(1.0, 4))
    assert batch.members[0][batch.mask[0]].tolist() == [0, 1]
    assert batch.is_virtual[0].tolist() == [False, True]  # N_1 = {1, 2} reaches 2


def test_centralised_game_has_every_robot_and_h_hop_pairs():
    pos = np.array([[0.0, 0], [50, 0], [100, 0], [150, 0]])
    game = centralised_game(disk_snapshot(pos, 60.0), 1, pos, DisplacementActions.headings(1.0, 4))
    assert game.members.tolist() == [[0, 1, 2, 3]] and game.owner.tolist() == [-1]
    pairs = game.valid_pairs()[0]
    assert pairs[0, 1] and pairs[1, 2] and not pairs[0, 2] and not pairs[0, 0]


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda s, p: broadcast(s, 0, p), r"h must be an integer >= 1 \(got 0\)"),
        (lambda s, p: broadcast(s, 2, p[:1]), r"states must have shape \(3, D\)"),
        (lambda s, p: broadcast(s, 2, p * np.nan), r"states must be finite \(robot 0"),
        (lambda s, p: gather_views(broadcast(s, 2, p), [5]), r"owners must be in \[0, 3\)"),
        (lambda s, p: receive(broadcast(s, 2, p), -1), r"owner must be in \[0, 3\) \(got -1\)"),
    ],
)
def test_invalid_inputs_are_rejected(call, match):
    pos = np.array([[0.0, 0], [10, 0], [20, 0]])
    with pytest.raises(ValueError, match=match):
        call(disk_snapshot(pos, 15.0), pos)


def test_batch_validates_shapes_and_is_read_only():
    with pytest.raises(ValueError, match=r"states must have shape \(1, 2, D\)"):
        LocalGameBatch(
            np.zeros(1),
            np.zeros((1, 2)),
            np.ones((1, 2)),
            np.zeros((1, 3, 2)),
            np.zeros((1, 2)),
            np.zeros((1, 2, 3, 2)),
            np.ones((1, 2, 3)),
        )
    pos = np.array([[0.0, 0], [10, 0]])
    batch = local_games(disk_snapshot(pos, 15.0), 1, pos, DisplacementActions.headings(1.0, 4))
    with pytest.raises(ValueError, match="read-only"):
        batch.states[0, 0, 0] = 1.0


def test_select_and_trim():
    pos = np.array([[0.0, 0], [10, 0], [20, 0], [1000, 0]])
    batch = local_games(disk_snapshot(pos, 15.0), 1, pos, DisplacementActions.headings(1.0, 4))
    sub = batch.select([3]).trim()
    assert sub.members.tolist() == [[3]] and sub.n_actions == 5


def test_action_model_without_actions_is_rejected():
    class Empty:
        n_actions = 0

        def apply(self, states):
            return states[..., None, :][..., :0, :]

    pos = np.array([[0.0, 0.0], [10.0, 0.0]])
    with pytest.raises(ValueError, match=r"action model n_actions must be >= 1 \(got 0\)"):
        local_games(disk_snapshot(pos, 15.0), 1, pos, Empty())


@pytest.mark.parametrize("mode", ["eq3", "outside"])
def test_the_owner_is_never_a_virtual_robot(mode):
    """N_i − N_i = ∅ (eq. 3): the owner keeps its own state even when its routing table (its
    reported N_i) lists a neighbour it has not heard from, as with routed delivery before a
    neighbour's first message arrives."""
    from swarmgames.game.local import LocalView, LocalViews

    model = DisplacementActions.headings(1.0, 4)
    members = np.array([[0, 1]], dtype=np.int32)
    views = LocalViews(
        owner=np.array([0], dtype=np.int32),
        members=members,
        mask=np.ones((1, 2), dtype=bool),
        states=np.array([[[0.0, 0.0], [1.0, 0.0]]]),
        mean_states=np.array([[[5.0, 5.0], [0.5, 0.0]]]),
        neighbourhoods=np.array([[[0, 1, 2], [0, 1, -1]]], dtype=np.int32),  # 2: not heard
    )
    batch = build_local_games(views, model, virtual_mean=mode)
    assert not batch.is_virtual.any()
    np.testing.assert_array_equal(batch.states[0, 0], [0.0, 0.0])
    one = build_local_game(
        LocalView(
            0,
            members[0],
            views.states[0],
            views.mean_states[0],
            (np.array([0, 1, 2]), np.array([0, 1])),
        ),
        model,
        virtual_mean=mode,
    )
    assert not one.is_virtual.any()


@pytest.mark.parametrize("shape", [(7,), (30, 300), (5, 4, 3)])
def test_pad_rows_compiled_copy_equals_the_numpy_gather(monkeypatch, shape):
    """Both ways of padding CSR rows (numpy below PAD_COMPILED_MIN rows, the compiled copy
    above) give the same array: rows of any length, empty rows and -1 rows included."""
    from swarmgames.game import local
    from swarmgames.game.local_compiled import compiled_pad_rows

    rng = np.random.default_rng(len(shape))
    lengths = rng.integers(0, 40, 500)
    lengths[:3] = 0
    indptr = np.concatenate([[0], np.cumsum(lengths)])
    indices = rng.integers(0, 10_000, indptr[-1]).astype(np.int32)
    rows = rng.integers(-1, 500, shape)
    monkeypatch.setattr(local, "PAD_COMPILED_MIN", 10**9)
    expect = local.pad_rows(indptr, indices, rows)
    got = compiled_pad_rows(indptr, indices, rows)
    assert got.dtype == expect.dtype == np.int32 and np.array_equal(got, expect)
    monkeypatch.setattr(local, "PAD_COMPILED_MIN", 0)
    assert np.array_equal(local.pad_rows(indptr, indices, rows), expect)
    none = np.full(shape, -1)
    assert np.array_equal(compiled_pad_rows(indptr, indices, none), np.full((*shape, 1), -1))
