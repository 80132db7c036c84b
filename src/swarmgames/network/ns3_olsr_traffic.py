"""What ns-3's OLSR puts on the air, per node: packets, messages and bytes.

Each node's ``olsr::RoutingProtocol`` fires its ``Tx`` trace source with the packet header and
the messages of every OLSR packet it sends (``SendPacket``). :class:`Ns3OlsrTraffic` counts
them, so that the built-in model's byte count (:mod:`swarmgames.network.olsr.wire`, one
message per packet, link messages grouped by link code) can be held against ns-3's packets:

* ns-3's ``SendHello`` writes one link message per neighbour (4 header bytes each);
* ``QueueMessage``/``SendQueuedMessages`` put every message queued before a send into one
  packet (a HELLO and a TC built together, a TC relayed while a send is pending), sharing one
  4-byte packet header and one 28-byte UDP/IP header.

The C++ sink is compiled once per ns-3 process with ``cppyy.cppdef`` (a trace source cannot
call into Python without a round trip per packet); :func:`compiled` and :func:`take_counts`
are the ns-3 process's side (:mod:`swarmgames.network.ns3_worker`).

References
----------
.. [1] ns-3 3.44 ``src/olsr/model/olsr-routing-protocol.cc`` (``SendHello``, ``QueueMessage``,
   ``SendQueuedMessages``, ``SendPacket``, trace source ``Tx``) and ``olsr-header.cc``.
.. [2] RFC 3626 sections 3.3 (packet format), 6.1 (HELLO), 9.1 (TC).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from swarmgames.arrays import freeze_fields

__all__ = ["Ns3OlsrCounts", "Ns3OlsrTraffic", "compiled", "take_counts"]

#: The counters, in the order of the C++ arrays.
FIELDS = (
    "packets",
    "packet_bytes",
    "shared_packets",
    "hello_sent",
    "hello_bytes",
    "hello_link_messages",
    "hello_neighbours",
    "tc_sent",
    "tc_bytes",
    "tc_forwarded",
    "tc_forwarded_bytes",
)

_CPP = r"""
namespace swarmgames_ns3_olsr {

// Counts the OLSR packets and messages of every node from its RoutingProtocol "Tx" trace.
class OlsrTxCounter {
  public:
    static constexpr int kFields = 11;
    explicit OlsrTxCounter(ns3::NodeContainer nodes)
        : m_n(nodes.GetN()), m_count(kFields * m_n, 0) {
        for (uint32_t i = 0; i < m_n; ++i) {
            auto node = nodes.Get(i);
            m_address.push_back(node->GetObject<ns3::Ipv4>()->GetAddress(1, 0).GetLocal());
            m_proto.push_back(node->GetObject<ns3::olsr::RoutingProtocol>());
            m_sink.push_back(ns3::MakeBoundCallback(&OlsrTxCounter::Tx, this, i));
            m_proto.back()->TraceConnectWithoutContext("Tx", m_sink.back());
        }
    }
    ~OlsrTxCounter() {
        for (uint32_t i = 0; i < m_n; ++i)
            m_proto[i]->TraceDisconnectWithoutContext("Tx", m_sink[i]);
    }
    // counts[f * n + i]: counter f (FIELDS in Python) of node i since the last Clear.
    const std::vector<uint64_t>& Counts() const { return m_count; }
    void Clear() { std::fill(m_count.begin(), m_count.end(), 0); }

  private:
    uint32_t m_n;
    std::vector<uint64_t> m_count;
    std::vector<ns3::Ipv4Address> m_address;
    std::vector<ns3::Ptr<ns3::olsr::RoutingProtocol>> m_proto;
    using Sink = ns3::Callback<void, const ns3::olsr::PacketHeader&,
                               const ns3::olsr::MessageList&>;
    std::vector<Sink> m_sink;

    void Add(int field, uint32_t i, uint64_t value) { m_count[size_t(field) * m_n + i] += value; }
    static void Tx(OlsrTxCounter* self, uint32_t i, const ns3::olsr::PacketHeader& header,
                   const ns3::olsr::MessageList& messages) {
        self->Add(0, i, 1);
        self->Add(1, i, header.GetPacketLength());
        self->Add(2, i, messages.size() > 1);
        for (const auto& m : messages) {
            if (m.GetMessageType() == ns3::olsr::MessageHeader::HELLO_MESSAGE) {
                self->Add(3, i, 1);
                self->Add(4, i, m.GetSerializedSize());
                const auto& links = m.GetHello().linkMessages;
                self->Add(5, i, links.size());
                for (const auto& l : links) self->Add(6, i, l.neighborInterfaceAddresses.size());
            } else if (m.GetMessageType() == ns3::olsr::MessageHeader::TC_MESSAGE) {
                bool own = m.GetOriginatorAddress() == self->m_address[i];
                self->Add(own ? 7 : 9, i, 1);
                self->Add(own ? 8 : 10, i, m.GetSerializedSize());
            }
        }
    }
};

}  // namespace swarmgames_ns3_olsr
"""


def compiled(ns: Any) -> Any:
    """The compiled C++ namespace (compiled at the first call in the ns-3 process)."""
    if not hasattr(ns.cppyy.gbl, "swarmgames_ns3_olsr"):
        ns.cppyy.cppdef(_CPP)
    return ns.cppyy.gbl.swarmgames_ns3_olsr


def take_counts(counter: Any, n: int) -> np.ndarray:
    """The C++ counter's counts since the last call, shape (len(FIELDS), n), which then
    restart (in the ns-3 process)."""
    view = counter.Counts().data()
    view.reshape((len(FIELDS) * n,))
    counts = np.array(view, dtype=np.int64, copy=True).reshape(len(FIELDS), n)
    counter.Clear()
    return counts


@dataclass(frozen=True, eq=False)
class Ns3OlsrCounts:
    """OLSR packets and messages each ns-3 node sent over an interval (read-only (N,) int64
    arrays).

    Parameters
    ----------
    packets, packet_bytes : ndarray
        OLSR packets and their bytes (packet header and messages; UDP/IP not included).
    shared_packets : ndarray
        Packets that carried more than one message.
    hello_sent, hello_bytes : ndarray
        HELLO messages and their bytes (message header and body).
    hello_link_messages, hello_neighbours : ndarray
        Link messages and neighbour addresses in those HELLOs.
    tc_sent, tc_bytes, tc_forwarded, tc_forwarded_bytes : ndarray
        TC messages originated and relayed, and their bytes.
    """

    packets: np.ndarray
    packet_bytes: np.ndarray
    shared_packets: np.ndarray
    hello_sent: np.ndarray
    hello_bytes: np.ndarray
    hello_link_messages: np.ndarray
    hello_neighbours: np.ndarray
    tc_sent: np.ndarray
    tc_bytes: np.ndarray
    tc_forwarded: np.ndarray
    tc_forwarded_bytes: np.ndarray

    def __post_init__(self) -> None:
        freeze_fields(self)

    @property
    def messages(self) -> np.ndarray:
        """HELLOs, TCs originated and TCs relayed."""
        return self.hello_sent + self.tc_sent + self.tc_forwarded


class Ns3OlsrTraffic:
    """Count the OLSR packets of every node of an ns-3 provider's current scenario.

    Parameters
    ----------
    provider : Ns3Provider
        A provider whose scenario is built; robot i is its node i. Counting changes nothing
        in the network.

    Examples
    --------
    >>> import numpy as np
    >>> from swarmgames.network.ns3_backend import Ns3Provider
    >>> line = np.array([[0.0, 0, 0], [300, 0, 0], [600, 0, 0]])
    >>> net = Ns3Provider(run=1)  # doctest: +SKIP
    >>> _ = net.reset(line)  # doctest: +SKIP
    >>> olsr = Ns3OlsrTraffic(net)  # doctest: +SKIP
    >>> net.step(30.0, line)  # doctest: +SKIP
    >>> olsr.take().hello_sent.tolist()  # doctest: +SKIP
    [15, 15, 15]
    """

    def __init__(self, provider: Any) -> None:
        self.provider = provider
        self._id = provider.call("olsr_open")

    def take(self) -> Ns3OlsrCounts:
        """The counts since the previous call (or construction); the counters restart."""
        counts = self.provider.call("olsr_take", self._id)
        return Ns3OlsrCounts(**dict(zip(FIELDS, counts, strict=True)))
