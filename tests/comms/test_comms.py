"""The communication layer: wire sizes by hand, flooding, belief tables, routed runs."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse import csgraph

from swarmgames.comms import BeliefTable, RoutedComms, airtime_s, flood, message_bytes
from swarmgames.config import parse_config
from swarmgames.network.oracle import OracleProvider
from swarmgames.sim import run
from swarmgames.topology import TopologySnapshot

# 802.11a at 6 Mbit/s, the wire format of swarmgames.comms.wire: 15 + 16 D + 4 |N_j| bytes.


def _line(n: int, spacing: float = 300.0) -> np.ndarray:
    return np.column_stack([np.arange(n) * spacing, np.zeros(n), np.full(n, 30.0)])


def _bfs_snapshot(pos: np.ndarray, radius: float = 368.84) -> TopologySnapshot:
    d = np.linalg.norm(pos[:, None, :] - pos[None, :, :], axis=-1)
    adj = sp.csr_array((d <= radius) & (d > 0))
    hops = csgraph.shortest_path(adj, unweighted=True)
    hops[~np.isfinite(hops)] = 0
    return TopologySnapshot.from_hop_matrix(0.0, hops.astype(int))


def test_byte_counts_on_a_three_robot_line_match_the_wire_format_by_hand():
    # Robots 0 - 1 - 2, 300 m apart (range 368.84 m), h = 2: every N_j holds all three, so
    # each message is 15 + 16*3 + 4*3 = 75 bytes. Robot 1 relays the messages of 0 and 2;
    # robots 0 and 2 each relay 1's message once (they first heard it one hop away).
    pos = _line(3)
    comms = RoutedComms(3, 3, 2)
    _, stats = comms.exchange(10.0, _bfs_snapshot(pos), pos, np.random.default_rng(0))
    assert message_bytes(3, [3]).tolist() == [75]
    np.testing.assert_array_equal(stats.bytes_sent, [75, 75, 75])
    np.testing.assert_array_equal(stats.messages_forwarded, [1, 2, 1])
    np.testing.assert_array_equal(stats.bytes_forwarded, [75, 150, 75])
    np.testing.assert_array_equal(stats.bytes_received, [150, 150, 150])
    # With h = 1 the ends report 2 members (71 bytes), the middle 3 (75); nobody relays.
    comms = RoutedComms(3, 3, 1)
    _, stats = comms.exchange(10.0, _bfs_snapshot(pos), pos, np.random.default_rng(0))
    np.testing.assert_array_equal(stats.bytes_sent, [71, 75, 71])
    np.testing.assert_array_equal(stats.messages_forwarded, [0, 0, 0])
    np.testing.assert_array_equal(stats.bytes_received, [75, 142, 75])


@pytest.mark.parametrize("h", [1, 2, 3])
def test_static_lossless_delivery_reaches_exactly_the_h_hop_members_one_latency_per_hop(h):
    rng = np.random.default_rng(4)
    pos = np.c_[rng.uniform(0, 1500, (25, 2)), np.full(25, 30.0)]
    snap = _bfs_snapshot(pos)
    comms = RoutedComms(25, 3, h, hop_delay_s=0.003)
    inbox, stats = comms.exchange(5.0, snap, pos, rng)
    hops = snap.hop_matrix()
    table = comms.table
    for i in range(25):
        heard = set(table.sender[table.owner == i].tolist())
        assert heard == {j for j in range(25) if 0 < hops[i, j] <= h}
    # Latency = hops x (delay + the sender's frame airtime).
    sizes = message_bytes(3, np.diff(snap.neighbourhood_matrix(h).indptr))
    want = hops[table.owner, table.sender] * (0.003 + airtime_s(sizes[table.sender], 6.0))
    np.testing.assert_allclose(table.arrival - table.stamp, want, rtol=1e-12)
    # Everything arrived before the decision: every member of N_i(h) is used, with the
    # state it has now, aged by the decision delay.
    assert np.all(stats.fresh_fraction == 1.0)
    views = inbox.views()
    ideal = __import__("swarmgames.game.local", fromlist=["broadcast"]).broadcast(snap, h, pos)
    ref = ideal.views()
    np.testing.assert_array_equal(views.members, ref.members)
    np.testing.assert_array_equal(views.states, ref.states)
    np.testing.assert_allclose(inbox.age[inbox.age > 0], comms.decide_after_s)


def test_flooding_uses_only_links_that_exist_physically_and_in_the_table():
    # The table still lists 0 - 1 (OLSR lag) but the robots are 1 km apart: nothing passes.
    pos = np.array([[0.0, 0, 30], [1000.0, 0, 30]])
    snap = TopologySnapshot.from_hop_matrix(0.0, np.array([[0, 1], [1, 0]]))
    inbox, stats = RoutedComms(2, 3, 2).exchange(1.0, snap, pos, np.random.default_rng(0))
    assert stats.messages_received.sum() == 0 and np.all(stats.fresh_fraction == 0)
    assert inbox.sizes.tolist() == [1, 1]  # each robot's game holds only itself


@pytest.mark.parametrize("seed", range(5))
def test_usable_links_are_the_physical_links_that_the_tables_list(seed):
    # The table lags the motion: some listed links are gone, some new ones unlisted. The
    # links a message can take are scipy's element-wise product of the two patterns.
    from swarmgames.comms.models import table_links
    from swarmgames.network.links import link_graph

    rng = np.random.default_rng(seed)
    before = np.c_[rng.uniform(0, 1500, (40, 2)), np.full(40, 30.0)]
    now = before + np.c_[rng.normal(0, 60.0, (40, 2)), np.zeros(40)]
    snap = _bfs_snapshot(before)
    comms = RoutedComms(40, 3, 2)
    got = comms._links(snap, now, rng)
    g = link_graph(now)
    phys = sp.csr_array((np.ones(g.indices.size, np.int8), g.indices, g.indptr), shape=(40, 40))
    want = phys.multiply(table_links(snap)).tocsr()
    want.sort_indices()
    assert np.array_equal(got.indptr, want.indptr) and np.array_equal(got.indices, want.indices)
    assert got.nnz and got.nnz < phys.nnz  # some physical links are not listed yet


def test_loss_draws_are_seeded_and_total_loss_isolates():
    pos = _line(5, 200.0)
    snap = _bfs_snapshot(pos)
    adj = sp.csr_array((np.abs(np.subtract.outer(range(5), range(5))) == 1).astype(int))

    def lossy(seed, p):
        rng = np.random.default_rng(seed)
        return flood(adj, 2, np.full(5, 10), link_success=lambda u, v: rng.random(u.size) >= p)

    np.testing.assert_array_equal(lossy(1, 0.5).receiver, lossy(1, 0.5).receiver)
    none = lossy(1, 1.0)
    assert none.receiver.size == 0 and none.bytes_received.sum() == 0
    comms = RoutedComms(5, 3, 2, loss_rate=1.0)
    _, stats = comms.exchange(0.0, snap, pos, np.random.default_rng(0))
    assert np.isnan(stats.info_age_s).all() and np.all(stats.fresh_fraction == 0)


def test_iid_loss_frequency_matches_the_loss_rate():
    # One hop, 2 robots, 4000 stages of messages: each direction is lost at rate p.
    pos = _line(2, 100.0)
    snap = _bfs_snapshot(pos)
    comms = RoutedComms(2, 3, 1, loss_rate=0.3)
    rng = np.random.default_rng(2)
    got = [comms.exchange(float(k), snap, pos, rng)[1].messages_received for k in range(4000)]
    assert np.mean(got) == pytest.approx(0.7, abs=0.02)


def test_gilbert_elliott_losses_come_in_bursts():
    # Same mean loss as i.i.d. p = 1/11 (stationary bad share 0.05 / (0.05 + 0.5)), but a
    # lost message is followed by another loss far more often than 1 in 11.
    pos = _line(2, 100.0)
    snap = _bfs_snapshot(pos)
    comms = RoutedComms(2, 3, 1, loss_model="gilbert_elliott")
    rng = np.random.default_rng(3)
    lost = np.array(
        [comms.exchange(float(k), snap, pos, rng)[1].messages_received[1] == 0 for k in range(6000)]
    )
    assert lost.mean() == pytest.approx(1 / 11, abs=0.02)
    assert lost[1:][lost[:-1]].mean() > 0.4  # P(lost | lost before) = 1 - 0.5


def test_fading_channel_draws_each_reception():
    # Rayleigh fading (Nakagami m = 1) at 300 m under Friis (mean power 7.3 dB above the
    # -82 dBm threshold): a frame arrives with probability exp(-10^(-7.3/10)) ~ 0.83.
    from swarmgames.network.parameters import RadioParameters
    from swarmgames.network.propagation import PropagationModel

    model = PropagationModel(RadioParameters(nakagami_m=1.0))
    margin = float(model.mean_rx_power(np.array([300.0]))[0]) + 82.0
    pos = _line(2, 300.0)
    comms = RoutedComms(2, 3, 1, propagation=model)
    rng = np.random.default_rng(4)
    snap = _bfs_snapshot(pos)
    got = [comms.exchange(float(k), snap, pos, rng)[1].messages_received[0] for k in range(3000)]
    assert np.mean(got) == pytest.approx(np.exp(-(10 ** (-margin / 10))), abs=0.03)


def _entries(owner, sender, stamp, arrival, x):
    n = len(owner)
    return BeliefTable(
        4,
        np.asarray(owner),
        np.asarray(sender),
        np.asarray(stamp, float),
        np.asarray(arrival, float),
        np.c_[np.asarray(x, float), np.zeros(n), np.zeros(n)],
        np.zeros((n, 3)),
        np.full((n, 1), -1, np.int32),
    )


def test_belief_table_keeps_the_newest_arrived_and_drops_the_stale():
    t = BeliefTable.empty(4, 3)
    t = t.merge(_entries([0, 0], [1, 2], [0.0, 0.0], [0.01, 0.01], [1.0, 2.0]), 0.1, 3.0)
    t = t.merge(_entries([0], [1], [1.0], [1.01], [5.0]), 1.1, 3.0)
    idx = t.lookup([0, 0, 0], [1, 2, 3], 1.1, 3.0)
    assert t.state[idx[0], 0] == 5.0 and t.state[idx[1], 0] == 2.0 and idx[2] == -1
    assert t.n_entries == 2  # the superseded message from robot 1 is gone
    # A message still in flight is kept but not used before it arrives.
    t = t.merge(_entries([0], [1], [2.0], [2.5], [9.0]), 2.1, 3.0)
    assert t.state[t.lookup([0], [1], 2.1, 3.0)[0], 0] == 5.0
    # Older than max_age: robot 2 (last heard at 0 s) is dropped at 3.5 s.
    t = t.merge(_entries([], [], [], [], []), 3.5, 3.0)
    assert t.lookup([0], [2], 3.5, 3.0)[0] == -1
    assert t.state[t.lookup([0], [1], 3.5, 3.0)[0], 0] == 9.0


def test_dead_reckoning_advances_reported_positions():
    comms = RoutedComms(2, 5, 1, dead_reckoning=True)
    comms.table = BeliefTable(
        2,
        np.array([0]),
        np.array([1]),
        np.array([0.0]),
        np.array([0.01]),
        np.array([[10.0, 0.0, 30.0, 2.0, -1.0]]),
        np.zeros((1, 5)),
        np.full((1, 1), -1, np.int32),
    )
    state, age = comms._believed(np.array([0]), 1.5)
    np.testing.assert_allclose(state[0, :3], [13.0, -1.5, 30.0])
    assert age[0] == 1.5


def _cfg(**comms):
    return parse_config(
        {
            "swarm": {"n_robots": 8, "start_radius_m": 300.0},
            "sim": {"duration_s": 15.0, "warmup_s": 2.0, "animation": False},
            "comms": {"model": "routed", **comms},
        }
    )


def test_information_age_grows_with_the_loss_rate():
    ages = []
    for loss in (0.0, 0.3, 0.6):
        res = run(_cfg(loss_rate=loss), progress=False, provider=OracleProvider(8))
        ages.append(np.nanmean(res.to_frame("metrics")["info_age_s"]))
        assert np.isfinite(res.to_frame("metrics")["payoff"]).all()
    assert ages[0] == pytest.approx(0.1) and ages[0] < ages[1] < ages[2]


def test_total_loss_leaves_isolated_robots_that_still_run():
    res = run(_cfg(loss_rate=1.0), progress=False, provider=OracleProvider(8))
    m = res.to_frame("metrics")
    assert (m["neighbours"] == 0).all() and (m["fresh_fraction"] == 0).all()
    assert (m["bytes_received"] == 0).all() and (m["bytes_sent"] > 0).all()
    assert res.summary["stages"] == 15


def test_routed_config_rules():
    from swarmgames.errors import ConfigError

    with pytest.raises(ConfigError, match=r"comms\.decide_after_s must be < sim\.control_period_s"):
        _cfg(decide_after_s=1.0)
    with pytest.raises(ConfigError, match=r"comms\.loss_rate: must be <= 1"):
        _cfg(loss_rate=1.5)


# ------------------------------------------------ virtual_mean = "exact": 2h-hop delivery


@pytest.mark.parametrize("h", [1, 2])
def test_context_floods_to_2h_hops_and_counts_the_longer_flood(h):
    # Robots on a line 300 m apart (range 368.84 m): hops = index distance. With context
    # (game.virtual_mean = "exact") a message travels 2h hops instead of h, so every robot
    # holds the states of robots up to 2h away, relays more and receives more bytes.
    n = 9
    pos = _line(n)
    snap = _bfs_snapshot(pos)
    plain = RoutedComms(n, 3, h)
    wide = RoutedComms(n, 3, h, context=True)
    assert (plain.reach, wide.reach) == (h, 2 * h)
    _, base = plain.exchange(10.0, snap, pos, np.random.default_rng(0))
    inbox, stats = wide.exchange(10.0, snap, pos, np.random.default_rng(0))
    for i in range(n):
        heard = set(wide.table.sender[wide.table.owner == i].tolist())
        assert heard == {j for j in range(n) if 0 < abs(i - j) <= 2 * h}
    assert stats.bytes_forwarded.sum() > base.bytes_forwarded.sum()
    assert stats.bytes_received.sum() > base.bytes_received.sum()
    np.testing.assert_array_equal(stats.bytes_sent, base.bytes_sent)  # the same messages
    # The inbox's context is ∪_{j ∈ N_i} N_j − N_i = the robots h+1 .. 2h hops away, at
    # their states of this stage, as the exact (ideal) inbox has them.
    from swarmgames.game.local import broadcast

    ref = broadcast(snap, h, pos).views(context=True)
    views = inbox.views(context=True)
    np.testing.assert_array_equal(views.members, ref.members)
    np.testing.assert_array_equal(views.context, ref.context)
    np.testing.assert_array_equal(views.context_states, ref.context_states)
    for i in range(n):
        got = set(views.context[i][views.context[i] >= 0].tolist())
        assert got == {j for j in range(n) if h < abs(i - j) <= 2 * h}
    np.testing.assert_allclose(stats.info_age_s, wide.decide_after_s)
    np.testing.assert_array_equal(stats.fresh_fraction, base.fresh_fraction)


def test_an_inbox_without_context_refuses_exact_views():
    pos = _line(3)
    inbox, _ = RoutedComms(3, 3, 1).exchange(1.0, _bfs_snapshot(pos), pos, np.random.default_rng(0))
    with pytest.raises(ValueError, match="holds no context states"):
        inbox.views(context=True)


def test_ideal_delivery_with_context_counts_the_context_receptions():
    from swarmgames.comms import IdealComms

    pos = _line(7)
    snap = _bfs_snapshot(pos)
    _, base = IdealComms(1).exchange(1.0, snap, pos)
    _, wide = IdealComms(1, context=True).exchange(1.0, snap, pos)
    # h = 1 on a line: N_i ∪ C_i is the robots within 2 hops.
    want = np.array([min(i, 2) + min(6 - i, 2) for i in range(7)])
    np.testing.assert_array_equal(wide.messages_received, want)
    np.testing.assert_array_equal(base.messages_received, [1, 2, 2, 2, 2, 2, 1])
    assert wide.bytes_received.sum() > base.bytes_received.sum()


def test_exact_run_with_routed_comms_costs_more_bytes_than_eq3():
    # The same run with game.virtual_mean = "exact" against "eq3": the state messages are
    # flooded 2h hops, so the bytes per robot and stage grow; the summary says which.
    out = {}
    for variant in ("eq3", "exact"):
        cfg = _cfg().with_overrides({"game.virtual_mean": variant, "network.hops": 1})
        res = run(cfg, progress=False, provider=OracleProvider(8))
        out[variant] = res.summary
        assert res.summary["virtual_mean"] == variant
    assert out["exact"]["bytes_per_robot_stage"] > out["eq3"]["bytes_per_robot_stage"]


def test_averaged_rows_let_receivers_take_the_shared_members_out_exactly():
    # game.virtual_mean = "outside" over routed delivery: a message's N_j lists the members
    # whose states its S̄_j averaged, so |N_j| S̄_j − Σ_{k ∈ N_j ∩ N_i} S_k is the sum over
    # j's outside members. On a static line the second stage's beliefs are the states
    # themselves and every S̄_j^out is the mean of the actual outside states (eq. 3 over
    # N_j − N_i); at the first stage j knows only itself and nobody is virtual.
    from swarmgames.game import DisplacementActions, build_local_games, local_games

    n, h = 9, 1
    pos = _line(n)
    pos[:, 1] = np.arange(n) ** 2.0  # distinct y, within range of the neighbours only
    pos[:, 0] = np.arange(n) * 250.0
    snap = _bfs_snapshot(pos)
    model = DisplacementActions.headings(1.0, 4, dim=3)
    comms = RoutedComms(n, 3, h, averaged_rows=True)
    first, stats = comms.exchange(1.0, snap, pos, np.random.default_rng(0))
    assert not build_local_games(first.views(), model, virtual_mean="outside").is_virtual.any()
    np.testing.assert_array_equal(stats.bytes_sent, message_bytes(3, np.ones(n, int)))
    second, _ = comms.exchange(2.0, snap, pos, np.random.default_rng(0))
    got = build_local_games(second.views(), model, virtual_mean="outside")
    want = local_games(snap, h, pos, model, virtual_mean="outside")
    np.testing.assert_array_equal(got.members, want.members)
    np.testing.assert_array_equal(got.is_virtual, want.is_virtual)
    assert got.is_virtual.any()
    np.testing.assert_allclose(got.states, want.states, rtol=1e-12, atol=1e-9)
