"""The ``ns3`` communication model: state messages as UDP packets in ns-3.

Tests marked ``ns3`` need the optional ``ns3`` package and skip with the install hint where it
is missing; the configuration and wire-format tests run everywhere.
"""

from __future__ import annotations

import numpy as np
import pytest

from swarmgames.comms import RoutedComms, airtime_s, flood, message_bytes
from swarmgames.comms.models import table_links
from swarmgames.comms.wire import decode_messages, encode_messages
from swarmgames.config import parse_config
from swarmgames.errors import BackendUnavailableError, ConfigError
from swarmgames.network import ns3_process

#: 802.11a DCF: a broadcast waits DIFS = SIFS (16 µs) + 2 slots (9 µs) on an idle medium.
DIFS_S = 34e-6
#: What an undisturbed hop adds to the built-in airtime: DIFS, the 16 SERVICE and 6 tail bits
#: and the rounding up to whole 4 µs OFDM symbols (at most 7.7 µs at 6 Mbit/s), and the
#: propagation over 300 m (1 µs).
UNDISTURBED_EXTRA_S = (DIFS_S, DIFS_S + 7.7e-6 + 1.1e-6)
#: A hop may also wait behind another frame (an OLSR HELLO: ~100 µs on the air) and a
#: backoff (at most 15 slots of 9 µs).
DISTURBED_EXTRA_S = 0.3e-3


@pytest.fixture(scope="module")
def ns3():
    """The ns-3 provider class, or a skip saying how to install ns-3."""
    try:
        ns3_process.shared_process()
    except BackendUnavailableError as exc:
        pytest.skip(str(exc))
    from swarmgames.network.ns3_backend import Ns3Provider

    return Ns3Provider


def line(n: int, d: float = 300.0) -> np.ndarray:
    return np.column_stack([np.arange(n) * d, np.zeros(n), np.full(n, 30.0)])


def grid(k: int, d: float = 300.0) -> np.ndarray:
    # Diagonals are 424 m > 368.84 m: links only along the rows and columns.
    return np.column_stack(
        [np.repeat(np.arange(k), k) * d, np.tile(np.arange(k), k) * d, np.full(k * k, 30.0)]
    )


def heard(table, t: float) -> set[tuple[int, int]]:
    """The (receiver, sender) pairs of a belief table's messages sent at ``t``."""
    now = table.stamp == t
    return set(zip(table.owner[now].tolist(), table.sender[now].tolist(), strict=True))


def settled(provider_cls, pos, seed=3):
    net = provider_cls(seed=seed)
    net.reset(pos)
    return net, net.advance(30.0, pos)


# -- everywhere --------------------------------------------------------------------------------


def test_wire_bytes_round_trip_and_have_the_documented_layout():
    rng = np.random.default_rng(0)
    state, mean = rng.normal(size=(3, 3)), rng.normal(size=(3, 3))
    indptr, members = np.array([0, 2, 2, 5]), np.array([0, 7, 1, 2, 9])
    buf, off = encode_messages([4, 5, 6], 12.5, state, mean, indptr, members)
    np.testing.assert_array_equal(np.diff(off), message_bytes(3, [2, 0, 3]))
    # sender uint32, timestamp float64, D uint8, |N_j| uint16, little-endian, no padding.
    assert buf[:15].tobytes() == (
        (4).to_bytes(4, "little") + np.float64(12.5).tobytes() + b"\x03" + b"\x02\x00"
    )
    got = decode_messages(buf, off)
    np.testing.assert_array_equal(got.sender, [4, 5, 6])
    np.testing.assert_array_equal(got.stamp, [12.5] * 3)
    np.testing.assert_array_equal(got.state, state)
    np.testing.assert_array_equal(got.mean, mean)
    np.testing.assert_array_equal(got.nbh, [[0, 7, -1], [-1, -1, -1], [1, 2, 9]])


def test_decoding_rejects_a_truncated_message():
    buf, off = encode_messages([0], 1.0, np.zeros((1, 2)), np.zeros((1, 2)), [0, 1], [0])
    with pytest.raises(ValueError, match="must be 15 \\+ 16 D \\+ 4 \\|N_j\\| = 51 bytes"):
        decode_messages(buf[:-1], [0, off[1] - 1])


@pytest.mark.parametrize(
    ("overrides", "field"),
    [
        (["comms.model=ns3"], "network.backend must be 'ns3'"),
        (["comms.model=ns3", "network.backend=ns3", "comms.loss_rate=0.1"], "comms.loss_rate"),
        (
            ["comms.model=ns3", "network.backend=ns3", "comms.loss_model=gilbert_elliott"],
            "comms.loss_model",
        ),
        (["comms.model=ns3", "network.backend=ns3", "comms.rate_mbps=54"], "comms.rate_mbps"),
        (["comms.model=ns3", "network.backend=ns3", "comms.decide_after_s=1"], "decide_after_s"),
    ],
)
def test_configurations_the_ns3_model_cannot_honour_name_the_field(overrides, field):
    from swarmgames.config import resolve_scenario

    with pytest.raises(ConfigError, match=field):
        resolve_scenario("coverage", overrides)


def test_the_ns3_model_with_the_ns3_backend_is_a_valid_configuration():
    cfg = parse_config({"network": {"backend": "ns3"}, "comms": {"model": "ns3", "jitter_s": 0.02}})
    assert (cfg.comms.model, cfg.comms.jitter_s) == ("ns3", 0.02)


def test_cli_rejects_the_ns3_model_without_the_ns3_backend(tmp_path):
    from click.testing import CliRunner

    from swarmgames.cli import cli

    res = CliRunner().invoke(cli, ["run", "--out", str(tmp_path / "x"), "--set", "comms.model=ns3"])
    assert res.exit_code == 2
    assert "network.backend must be 'ns3'" in res.output


# -- with ns-3 ---------------------------------------------------------------------------------


@pytest.mark.ns3
@pytest.mark.parametrize("layout", [line(7), grid(3)], ids=["line7", "grid3x3"])
def test_packet_flood_equals_builtin_flood_on_a_static_layout(ns3, layout):
    # Lossless links, fading off, and a schedule without overlapping frames: robot s sends at
    # 10 ms * s, robot v relays 0.5 ms * (v + 1) after it heard (> the 0.23 ms of a frame).
    from swarmgames.network.ns3_packets import StateFlood

    n = len(layout)
    net, snap = settled(ns3, layout)
    links = table_links(snap)
    links.sort_indices()
    nbh = snap.neighbourhood_matrix(2)
    nbh.sort_indices()
    buf, off = encode_messages(np.arange(n), 30.0, layout, layout, nbh.indptr, nbh.indices)
    jitter = np.tile(0.5e-3 * (np.arange(n)[:, None] + 1.0), (1, n))
    np.fill_diagonal(jitter, 0.01 * np.arange(n))
    packets = StateFlood(net, 2)
    packets.send(buf, off, np.ones(n, bool), links.indptr, links.indices, jitter)
    packets.run_until(30.5)
    rx, tx = packets.drain()
    builtin = flood(links, 2, np.diff(off))
    got = sorted(zip(rx.receiver.tolist(), rx.sender.tolist(), rx.hops.tolist(), strict=True))
    want = zip(
        builtin.receiver.tolist(), builtin.sender.tolist(), builtin.hops.tolist(), strict=True
    )
    assert got == sorted(want)
    np.testing.assert_array_equal(np.bincount(tx.node[tx.relay], minlength=n), builtin.forwarded)
    np.testing.assert_array_equal(tx.node[~tx.relay], np.arange(n))
    # Every datagram, own or relayed, sent or received, is the wire format's size.
    np.testing.assert_array_equal(tx.size, np.diff(off)[tx.sender])
    np.testing.assert_array_equal(rx.size, np.diff(off)[rx.sender])
    # Age on arrival minus the jitter on the way: hops x (built-in airtime + ns-3's extra).
    waited = jitter[rx.sender, rx.sender] + np.where(
        rx.hops > 1, jitter[rx.transmitter, rx.sender], 0
    )
    extra = (rx.time - 30.0 - waited) / rx.hops - airtime_s(rx.size, 6.0)
    lo, hi = UNDISTURBED_EXTRA_S
    assert np.all(extra >= lo - 1e-9) and np.all(extra <= DISTURBED_EXTRA_S)
    assert np.mean((extra >= lo - 1e-9) & (extra <= hi)) >= 0.9
    decoded = decode_messages(rx.payload, rx.offsets)
    np.testing.assert_array_equal(decoded.sender, rx.sender)
    np.testing.assert_array_equal(decoded.state, layout[rx.sender])


@pytest.mark.ns3
def test_model_delivers_a_share_of_what_the_routed_model_delivers_and_nothing_else(ns3):
    # Five robots within range of each other, h = 2: the routed model delivers every message
    # directly. In ns-3 two robots that waited behind the same frame may draw the same
    # backoff slot and collide (a broadcast has no ACK and no retry), so it delivers a part of
    # that (the whole of it in most stages), and nothing the routed model would not.
    from swarmgames.comms.ns3_comms import Ns3Comms

    rng = np.random.default_rng(2)
    pos = np.c_[rng.uniform(0, 200, (5, 2)), np.full(5, 30.0)]
    net, snap = settled(ns3, pos)
    comms = Ns3Comms(5, 3, 2, net, jitter_s=0.01)
    routed = RoutedComms(5, 3, 2)
    delivered = []
    for t in (30.0, 31.0, 32.0):
        snap = net.advance(t, pos)
        inbox, stats = comms.exchange(t, snap, pos, np.random.default_rng(int(t)))
        _, want = routed.exchange(t, snap, pos, np.random.default_rng(0))
        got, full = heard(comms.table, t), heard(routed.table, t)
        assert got <= full
        delivered.append(len(got) / len(full))
        rx, tx = comms.receptions, comms.transmissions
        np.testing.assert_array_equal(stats.messages_received, np.bincount(rx.receiver, None, 5))
        np.testing.assert_array_equal(stats.bytes_sent, want.bytes_sent)
        np.testing.assert_array_equal(
            stats.messages_forwarded, np.bincount(tx.node[tx.relay], None, 5)
        )
        # One hop: the jitter (<= 10 ms), then channel access and airtime, behind at most the
        # 24 other frames of the stage.
        age = comms.table.arrival[comms.table.stamp == t] - t
        frame = airtime_s(message_bytes(3, 5), 6.0) + DIFS_S
        assert np.all(age > frame) and np.all(age <= 0.01 + 25 * (frame + DISTURBED_EXTRA_S))
        np.testing.assert_allclose(stats.info_age_s[inbox.sizes > 1], 0.1)
    assert np.mean(delivered) >= 0.75


@pytest.mark.ns3
def test_run_fills_the_comms_columns_from_ns3_receptions(ns3):
    from swarmgames.comms.ns3_comms import Ns3Comms
    from swarmgames.config import resolve_scenario
    from swarmgames.sim.controllers import make_controller
    from swarmgames.sim.loop import run_stages
    from swarmgames.sim.providers import comms_from_config, provider_from_config
    from swarmgames.sim.runner import build_mission

    cfg = resolve_scenario(
        "coverage",
        ["network.backend=ns3", "comms.model=ns3", "sim.duration_s=4", "swarm.n_robots=5"],
    )
    mission = build_mission(cfg)
    rng = np.random.default_rng(0)
    states = mission.initial_states(5, rng)
    net = provider_from_config(cfg.network, 5, 1)
    comms = comms_from_config(cfg, states.shape[1], net)
    assert isinstance(comms, Ns3Comms)
    seen = []
    exchange = comms.exchange

    def recording(*args, **kwargs):
        out = exchange(*args, **kwargs)
        seen.append((comms.receptions, comms.transmissions))
        return out

    comms.exchange = recording
    log = run_stages(
        provider=net,
        controller=make_controller(cfg, mission),
        mission=mission,
        states=states,
        n_stages=4,
        period_s=1.0,
        warmup_s=cfg.sim.warmup_s,
        rng=rng,
        comms=comms,
        comms_rng=np.random.default_rng(1),
    )
    per = log.per_robot
    for k, (rx, tx) in enumerate(seen):
        np.testing.assert_array_equal(
            per["messages_received"][k], np.bincount(rx.receiver, minlength=5)
        )
        np.testing.assert_array_equal(
            per["bytes_received"][k], np.bincount(rx.receiver, rx.size, 5)
        )
        np.testing.assert_array_equal(
            per["bytes_forwarded"][k], np.bincount(tx.node, tx.size * tx.relay, 5)
        )
    assert per["messages_received"].sum() > 0


@pytest.mark.ns3
def test_cli_and_api_runs_with_the_ns3_model(ns3, tmp_path):
    import pandas as pd
    from click.testing import CliRunner

    from swarmgames.cli import cli

    out = tmp_path / "run"
    args = ["run", "--out", str(out), "--no-progress", "--set", "network.backend=ns3"]
    args += ["--set", "comms.model=ns3", "--set", "sim.duration_s=3"]
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 0, res.output
    metrics = pd.read_csv(out / "metrics.csv")
    assert (metrics["bytes_sent"] == message_bytes(3, metrics["neighbours"] + 1)).all()
    assert metrics["messages_received"].sum() > 0


@pytest.mark.ns3
@pytest.mark.parametrize("variant", ["outside", "exact"])
def test_runs_with_the_ns3_model_for_the_virtual_mean_variants(ns3, tmp_path, variant):
    import pandas as pd
    from click.testing import CliRunner

    from swarmgames.cli import cli

    out = tmp_path / variant
    args = ["run", "--out", str(out), "--no-progress", "--set", "network.backend=ns3"]
    args += ["--set", "comms.model=ns3", "--set", "sim.duration_s=3"]
    args += ["--set", f"game.virtual_mean={variant}"]
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 0, res.output
    metrics = pd.read_csv(out / "metrics.csv")
    assert metrics["messages_received"].sum() > 0
    # "outside" messages list only the members their mean averaged: never more bytes.
    assert (metrics["bytes_sent"] <= message_bytes(3, metrics["neighbours"] + 1)).all()


@pytest.mark.ns3
def test_context_floods_the_packets_for_2h_hops(ns3):
    # game.virtual_mean = "exact" with h = 1 on a line 300 m apart: the datagrams are relayed
    # once (TTL 2h = 2, where h = 1 relays nothing), so robots hear those two hops away, and
    # their states fill the inboxes' contexts, ∪_j N_j − N_i = the robots 2 hops away.
    from swarmgames.comms.ns3_comms import Ns3Comms

    pos = line(7)
    net, _ = settled(ns3, pos)
    comms = Ns3Comms(7, 3, 1, net, context=True)
    assert comms.reach == 2
    inbox, stats = comms.exchange(31.0, net.advance(31.0, pos), pos, np.random.default_rng(0))
    got = heard(comms.table, 31.0)
    assert got <= {(i, j) for i in range(7) for j in range(7) if 0 < abs(i - j) <= 2}
    assert any(abs(i - j) == 2 for i, j in got)
    assert stats.messages_forwarded.sum() > 0
    views = inbox.views(context=True)
    for i in range(7):
        ctx = set(views.context[i][views.context[i] >= 0].tolist())
        assert ctx and ctx <= {j for j in range(7) if abs(i - j) == 2}
        assert {(i, j) for j in ctx} <= got
