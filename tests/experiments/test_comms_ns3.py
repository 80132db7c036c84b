"""``swarmgames reproduce comms-ns3``: built-in routed delivery against UDP packets in ns-3."""

from __future__ import annotations

import numpy as np
import pytest

from swarmgames.errors import BackendUnavailableError, ConfigError
from swarmgames.experiments.comms_ns3 import compare_control_traffic, compare_delivery
from swarmgames.network import ns3_process


@pytest.fixture(scope="module")
def ns3():
    try:
        ns3_process.shared_process()
    except BackendUnavailableError as exc:
        pytest.skip(str(exc))


def test_unknown_trace_and_bad_runs_are_config_errors():
    with pytest.raises(ConfigError, match="'nowhere' is not a recorded trace"):
        compare_delivery(["nowhere"], [1])
    with pytest.raises(ConfigError, match="runs"):
        compare_delivery(["static_20"], [0])


@pytest.mark.ns3
def test_static_trace_routed_delivers_everything_ns3_most_of_it(ns3, tmp_path):
    from swarmgames.runfolder import RunFolder

    res = compare_delivery(["static_20"], [1], warmup_s=36.0)
    f = res.frame.set_index(["model", "hops"])
    # Built-in, lossless: every member within 2 hops, one hop latency per hop.
    np.testing.assert_array_equal(f.loc["routed", "delivery_ratio"], [1.0, 1.0])
    ages = f.loc["routed", "mean_age_ms"].to_numpy()
    np.testing.assert_allclose(ages[1], 2 * ages[0], rtol=0.05)
    # ns-3: collisions lose some, more at two hops; ages hold the jitter (uniform, 40 ms).
    ratio = f.loc["ns3", "delivery_ratio"].to_numpy()
    assert 0.5 < ratio[1] <= ratio[0] <= 1.0
    assert 10.0 < f.loc["ns3", "mean_age_ms"].iloc[0] < 40.0
    agg = res.aggregate()
    assert set(agg["model"]) == {"routed", "ns3"} and (agg["runs"] == 1).all()
    written = res.write(RunFolder(tmp_path / "out"))
    assert {p.name for p in written} == {"delivery.csv", "delivery_aggregate.csv", "delivery.png"}


@pytest.mark.ns3
def test_ns3_olsr_packs_messages_and_writes_one_link_message_per_neighbour(ns3):
    from swarmgames.network.ns3_backend import Ns3Provider
    from swarmgames.network.ns3_olsr_traffic import Ns3OlsrTraffic

    # Three robots in a line (300 m): the middle one has two neighbours, the ends one each.
    line = np.array([[0.0, 0, 0], [300, 0, 0], [600, 0, 0]])
    net = Ns3Provider(run=1)
    net.reset(line)
    counter = Ns3OlsrTraffic(net)
    net.step(60.0, line)
    k = counter.take()
    np.testing.assert_array_equal(k.hello_link_messages, k.hello_neighbours)
    # A HELLO is a 12-byte message header, 4 bytes of HELLO header and 8 per neighbour:
    # hello_size(k, k) of swarmgames.network.olsr.wire less the 4-byte packet header.
    np.testing.assert_array_equal(k.hello_bytes, k.hello_sent * 16 + 8 * k.hello_neighbours)
    assert k.hello_sent.tolist() == [30, 30, 30]
    assert (k.packets < k.messages).any() and (k.packets <= k.messages).all()
    assert 0 < k.shared_packets.sum() <= (k.messages - k.packets).sum()


@pytest.mark.ns3
def test_control_traffic_comparison_counts_both_backends(ns3):
    res = compare_control_traffic(["static_7"], [1], warmup_s=20.0)
    f = res.frame.set_index("backend")
    # HELLO every 2 s on both; the model sends one message per packet, ns-3 packs some.
    np.testing.assert_allclose(f["hello_per_s"], 0.5, rtol=0.05)
    assert f.loc["olsr", "shared_packets"] == 0 and f.loc["ns3", "shared_packets"] > 0
    assert f.loc["ns3", "packets_per_s"] < f.loc["ns3", "hello_per_s"] + f.loc["ns3", "tc_per_s"]
