"""State messages as UDP packets in ns-3: broadcast, relayed for h hops, timed by ns-3.

The ``ns3`` communication model (:mod:`swarmgames.comms.ns3_comms`) hands every robot's
wire-format message (:mod:`swarmgames.comms.wire`) to :class:`StateFlood`, which runs on the
nodes of an :class:`~swarmgames.network.ns3_backend.Ns3Provider`:

* every node has one UDP socket on :data:`STATE_PORT`; a message goes out as one IPv4
  limited broadcast (255.255.255.255) whose UDP payload is exactly the wire bytes, so
  802.11a's DCF, collisions, hidden terminals, OLSR's own packets and the propagation model
  decide who hears it and when;
* a robot that hears a message for the first time (a newer timestamp from that sender than
  any it heard) and which has travelled fewer than ``ttl`` hops broadcasts it again, once:
  application-level flooding, as the built-in routed model does
  (:func:`swarmgames.comms.flooding.flood`);
* a frame from transmitter u counts at receiver v only where u's routing table lists v as a
  1-hop (symmetric) neighbour, the built-in model's rule (``links``): a robot knows this from
  u's HELLOs, which list the link's status;
* each transmission, original or relay, waits a random ``jitter`` first (drawn by the
  caller from its seeded numpy Generator): without it the robots of a stage would all start
  transmitting in the same slot and collide (RFC 3626 section 3.5 jitters OLSR's own
  messages for the same reason);
* every first reception is recorded with ``Simulator::Now()``, and every transmission with
  its size as the socket took it.

ns-3 sends every IPv4 broadcast with TTL 1 (``UdpSocketImpl::DoSendTo``: "the TTL will later be
set to one irrespective of what is set in these socket options"), so the hops a copy has
travelled ride beside the packet in an ns-3 packet tag, ``HopsTag``, which puts no bytes on the
air; a real robot would read them from the IP TTL (``IP_RECVTTL``).

The C++ part is compiled once per ns-3 process with ``cppyy.cppdef`` (about 2 s): a receive
callback cannot be a Python function without a round trip into Python for every packet.
:class:`StateFlood` sends its requests to the provider's ns-3 process
(:mod:`swarmgames.network.ns3_process`); :func:`compiled`, :func:`schedule` and
:func:`drain_events` are that process's side.

References
----------
.. [1] ns-3 3.44 model library, "Sockets APIs" (``Socket::CreateSocket``, ``SetAllowBroadcast``,
   ``SetRecvCallback``, ``RecvFrom``) and "Packets" (packet tags) chapters;
   ``src/internet/model/udp-socket-impl.cc`` (broadcast TTL).
.. [2] RFC 3626, "Optimized Link State Routing Protocol (OLSR)", section 3.5 (jitter).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from swarmgames.arrays import freeze_fields

__all__ = [
    "STATE_PORT",
    "PacketReceptions",
    "PacketTransmissions",
    "StateFlood",
    "compiled",
    "drain_events",
    "schedule",
]

#: UDP port of the state messages (OLSR's is 698).
STATE_PORT = 5800

_CPP = r"""
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <unordered_map>

namespace swarmgames_ns3 {

// Hops a copy of a state message has travelled: ns-3 forces TTL 1 on broadcasts, so this
// stands in for the IP TTL; a packet tag is simulation metadata and puts no byte on the air.
class HopsTag : public ns3::Tag {
  public:
    uint8_t hops = 0;
    static ns3::TypeId GetTypeId() {
        static ns3::TypeId tid = ns3::TypeId("swarmgames::HopsTag")
                                     .SetParent<ns3::Tag>()
                                     .SetGroupName("swarmgames")
                                     .AddConstructor<HopsTag>();
        return tid;
    }
    ns3::TypeId GetInstanceTypeId() const override { return GetTypeId(); }
    uint32_t GetSerializedSize() const override { return 1; }
    void Serialize(ns3::TagBuffer b) const override { b.WriteU8(hops); }
    void Deserialize(ns3::TagBuffer b) override { hops = b.ReadU8(); }
    void Print(std::ostream& os) const override { os << "hops=" << int(hops); }
};

// One UDP broadcast socket per node; first receptions are relayed while hops remain.
class StateFlood {
  public:
    StateFlood(ns3::NodeContainer nodes, uint16_t port, uint8_t ttl)
        : m_n(nodes.GetN()), m_ttl(ttl), m_port(port),
          m_newest(size_t(m_n) * m_n, -std::numeric_limits<double>::infinity()),
          m_jitter(size_t(m_n) * m_n, 0.0), m_linkptr(m_n + 1, 0) {
        for (uint32_t i = 0; i < m_n; ++i) {
            ns3::Ptr<ns3::Node> node = nodes.Get(i);
            m_index[node->GetObject<ns3::Ipv4>()->GetAddress(1, 0).GetLocal().Get()] = i;
            m_node[node->GetId()] = i;
            m_context.push_back(node->GetId());
            auto s = ns3::Socket::CreateSocket(node, ns3::UdpSocketFactory::GetTypeId());
            if (s->Bind(ns3::InetSocketAddress(ns3::Ipv4Address::GetAny(), port)) < 0)
                throw std::runtime_error("UDP port " + std::to_string(port) + " is taken on node "
                                         + std::to_string(i) + " (an open StateFlood?)");
            s->SetAllowBroadcast(true);
            s->SetRecvCallback(ns3::MakeCallback(&StateFlood::Receive, this));
            m_sockets.push_back(s);
        }
    }
    ~StateFlood() {  // the sockets may outlive this object inside ns-3
        for (auto& s : m_sockets)
            s->SetRecvCallback(ns3::MakeNullCallback<void, ns3::Ptr<ns3::Socket>>());
    }
    // Free the port (only while the scenario that owns the sockets runs).
    void Close() {
        for (auto& s : m_sockets) {
            s->SetRecvCallback(ns3::MakeNullCallback<void, ns3::Ptr<ns3::Socket>>());
            s->Close();
        }
        m_sockets.clear();
    }
    // links (CSR over transmitters): receiver v counts frames of transmitter u.
    void SetLinks(const int64_t* indptr, const int64_t* indices) {
        m_linkptr.assign(indptr, indptr + m_n + 1);
        m_links.assign(indices, indices + indptr[m_n]);
    }
    // jitter[v * n + s]: wait of robot v before it transmits s's message, seconds.
    void SetJitter(const double* jitter) { m_jitter.assign(jitter, jitter + size_t(m_n) * m_n); }
    // Schedule the message of every robot i with send[i] (buffer[offsets[i]:offsets[i+1]]).
    void Send(const uint8_t* buffer, const int64_t* offsets, const uint8_t* send) {
        for (uint32_t i = 0; i < m_n; ++i) {
            if (!send[i]) continue;
            uint32_t size = uint32_t(offsets[i + 1] - offsets[i]);
            auto p = ns3::Create<ns3::Packet>(buffer + offsets[i], size);
            Schedule(i, i, p, 1, false);
        }
    }
    // Recorded events: first receptions and transmissions since the last Clear.
    std::vector<uint32_t> rx_receiver, rx_transmitter, rx_sender, rx_hops, rx_size;
    std::vector<double> rx_time;
    std::vector<uint8_t> rx_payload;
    std::vector<uint32_t> tx_node, tx_sender, tx_size;
    std::vector<uint8_t> tx_relay;
    std::vector<double> tx_time;
    void Clear() {
        for (auto* v : {&rx_receiver, &rx_transmitter, &rx_sender, &rx_hops, &rx_size, &tx_node,
                        &tx_sender, &tx_size}) v->clear();
        rx_time.clear(); rx_payload.clear(); tx_relay.clear(); tx_time.clear();
    }

  private:
    uint32_t m_n;
    uint8_t m_ttl;
    uint16_t m_port;
    std::vector<double> m_newest, m_jitter;
    std::vector<int64_t> m_linkptr, m_links;
    std::unordered_map<uint32_t, uint32_t> m_index, m_node;
    std::vector<uint32_t> m_context;
    std::vector<ns3::Ptr<ns3::Socket>> m_sockets;

    void Schedule(uint32_t v, uint32_t s, ns3::Ptr<ns3::Packet> p, uint8_t hops, bool relay) {
        auto wait = ns3::Seconds(m_jitter[size_t(v) * m_n + s]);
        ns3::Simulator::ScheduleWithContext(m_context[v], wait, &StateFlood::Transmit, this, v, s,
                                            p, hops, relay);
    }
    void Transmit(uint32_t v, uint32_t s, ns3::Ptr<ns3::Packet> p, uint8_t hops, bool relay) {
        HopsTag tag;
        tag.hops = hops;
        auto q = p->Copy();
        q->AddPacketTag(tag);
        auto to = ns3::InetSocketAddress(ns3::Ipv4Address::GetBroadcast(), m_port);
        if (m_sockets[v]->SendTo(q, 0, to) < 0) return;
        tx_node.push_back(v); tx_sender.push_back(s); tx_size.push_back(p->GetSize());
        tx_relay.push_back(relay); tx_time.push_back(ns3::Simulator::Now().GetSeconds());
    }
    bool Linked(uint32_t u, uint32_t v) const {
        auto first = m_links.begin() + m_linkptr[u], last = m_links.begin() + m_linkptr[u + 1];
        return std::binary_search(first, last, int64_t(v));
    }
    void Receive(ns3::Ptr<ns3::Socket> socket) {
        ns3::Address from;
        ns3::Ptr<ns3::Packet> p;
        uint32_t v = m_node[socket->GetNode()->GetId()];
        while ((p = socket->RecvFrom(from))) {
            auto it = m_index.find(ns3::InetSocketAddress::ConvertFrom(from).GetIpv4().Get());
            HopsTag tag;
            if (it == m_index.end() || !Linked(it->second, v) || !p->PeekPacketTag(tag)) continue;
            uint32_t size = p->GetSize();
            if (size < 15) continue;
            std::vector<uint8_t> bytes(size);
            p->CopyData(bytes.data(), size);
            uint32_t s;
            double stamp;  // little-endian on the wire and on x86-64, the bindings' platform
            std::memcpy(&s, bytes.data(), 4);
            std::memcpy(&stamp, bytes.data() + 4, 8);
            if (s >= m_n || s == v || !(stamp > m_newest[size_t(v) * m_n + s])) continue;
            m_newest[size_t(v) * m_n + s] = stamp;
            rx_receiver.push_back(v); rx_transmitter.push_back(it->second); rx_sender.push_back(s);
            rx_hops.push_back(tag.hops); rx_size.push_back(size);
            rx_time.push_back(ns3::Simulator::Now().GetSeconds());
            rx_payload.insert(rx_payload.end(), bytes.begin(), bytes.end());
            if (tag.hops < m_ttl) {
                p->RemoveAllPacketTags();
                Schedule(v, s, p, tag.hops + 1, true);
            }
        }
    }
};

}  // namespace swarmgames_ns3
"""


def compiled(ns: Any) -> Any:
    """The compiled C++ namespace (compiled at the first call in the ns-3 process)."""
    if not hasattr(ns.cppyy.gbl, "swarmgames_ns3"):
        ns.cppyy.cppdef(_CPP)
    return ns.cppyy.gbl.swarmgames_ns3


def schedule(flood: Any, buffer, offsets, senders, links_indptr, links_indices, jitter) -> None:
    """Hand the C++ ``StateFlood`` the links, the jitter and the messages of
    :meth:`StateFlood.send` (in the ns-3 process)."""
    n = int(np.asarray(senders).size)
    flood.SetLinks(
        np.ascontiguousarray(links_indptr, dtype=np.int64),
        np.ascontiguousarray(links_indices, dtype=np.int64),
    )
    flood.SetJitter(np.ascontiguousarray(np.reshape(jitter, n * n), dtype=np.float64))
    flood.Send(
        np.ascontiguousarray(buffer, dtype=np.uint8),
        np.ascontiguousarray(offsets, dtype=np.int64),
        np.ascontiguousarray(senders, dtype=np.uint8),
    )


#: The C++ ``StateFlood``'s event vectors and their dtypes, as :func:`drain_events` reads them.
_EVENTS = {
    "rx_receiver": np.int64,
    "rx_transmitter": np.int64,
    "rx_sender": np.int64,
    "rx_hops": np.int64,
    "rx_time": np.float64,
    "rx_size": np.int64,
    "rx_payload": np.uint8,
    "tx_node": np.int64,
    "tx_sender": np.int64,
    "tx_relay": np.uint8,
    "tx_size": np.int64,
    "tx_time": np.float64,
}


def drain_events(flood: Any) -> dict[str, np.ndarray]:
    """The C++ ``StateFlood``'s receptions and transmissions since the last call, as arrays
    named as its vectors, which are then cleared (in the ns-3 process)."""
    events = {name: _array(getattr(flood, name), dtype) for name, dtype in _EVENTS.items()}
    flood.Clear()
    return events


def _array(vec: Any, dtype: Any) -> np.ndarray:
    """A numpy copy of a C++ ``std::vector``."""
    n = int(vec.size())
    if n == 0:
        return np.zeros(0, dtype=dtype)
    view = vec.data()
    view.reshape((n,))
    return np.array(view, dtype=dtype, copy=True)


@dataclass(frozen=True, eq=False)
class PacketReceptions:
    """First receptions of state messages, R of them (read-only arrays).

    Parameters
    ----------
    receiver, transmitter, sender : ndarray of int64, shape (R,)
        Who heard it, from whom (the sender or a relay), and whose message it is.
    hops : ndarray of int64, shape (R,)
        Hops the message had travelled (1: heard from its sender).
    time : ndarray of float64, shape (R,)
        ``Simulator::Now()`` at the reception, ns-3 seconds.
    size : ndarray of int64, shape (R,)
        UDP payload, bytes.
    payload : ndarray of uint8
        The received payloads back to back; reception r is
        ``payload[offsets[r]:offsets[r + 1]]``.
    offsets : ndarray of int64, shape (R + 1,)
    """

    receiver: np.ndarray
    transmitter: np.ndarray
    sender: np.ndarray
    hops: np.ndarray
    time: np.ndarray
    size: np.ndarray
    payload: np.ndarray
    offsets: np.ndarray

    def __post_init__(self) -> None:
        freeze_fields(self)


@dataclass(frozen=True, eq=False)
class PacketTransmissions:
    """Datagrams handed to the sockets, T of them (read-only arrays).

    Parameters
    ----------
    node, sender : ndarray of int64, shape (T,)
        The transmitting robot and whose message it carried.
    relay : ndarray of bool, shape (T,)
        A relay (False: the sender's own transmission).
    size : ndarray of int64, shape (T,)
        UDP payload, bytes.
    time : ndarray of float64, shape (T,)
        When the socket took it, ns-3 seconds.
    """

    node: np.ndarray
    sender: np.ndarray
    relay: np.ndarray
    size: np.ndarray
    time: np.ndarray

    def __post_init__(self) -> None:
        freeze_fields(self)


class StateFlood:
    """UDP flooding of state messages on the nodes of an ns-3 provider (module docstring).

    Parameters
    ----------
    provider : Ns3Provider
        A provider whose scenario is built (``reset`` called); robot i is its node i.
    ttl : int
        Largest number of hops a message travels, 1 to 255 (the neighbourhood radius h).
    port : int, default :data:`STATE_PORT`

    Raises
    ------
    RuntimeError
        If the provider's scenario was destroyed or never built, or ``port`` is taken on its
        nodes (by another open :class:`StateFlood`: close it first).
    ValueError
        If ``ttl`` is out of range.
    Ns3CrashError
        From :meth:`run_until` (and any method), if ns-3 aborts.
    """

    def __init__(self, provider: Any, ttl: int, port: int = STATE_PORT) -> None:
        if not 1 <= int(ttl) <= 255:
            raise ValueError(f"ttl must be in [1, 255] (got {ttl})")
        self.provider = provider
        self.ttl = int(ttl)
        self._id, self.n_robots = provider.call("flood_open", self.ttl, int(port))
        self._scenario = provider.scenario

    @property
    def live(self) -> bool:
        """Whether the provider still runs the scenario these sockets were opened in."""
        return self.provider.scenario == self._scenario

    def close(self) -> None:
        """Close the sockets, freeing the port (nothing to do once the scenario is gone)."""
        if self.live:
            self.provider.call("flood_close", self._id)

    @property
    def now(self) -> float:
        """ns-3's clock, seconds."""
        return float(self.provider.call("now"))

    def send(self, buffer, offsets, senders, links_indptr, links_indices, jitter) -> None:
        """Schedule one message per robot with ``senders`` true, from now on.

        Parameters
        ----------
        buffer : ndarray of uint8
            The messages back to back (:func:`~swarmgames.comms.wire.encode_messages`);
            robot i's is ``buffer[offsets[i]:offsets[i + 1]]``.
        offsets : ndarray of int64, shape (N + 1,)
        senders : ndarray of bool, shape (N,)
        links_indptr, links_indices : ndarray of int64
            CSR over transmitters, sorted rows: receiver v counts frames of u when v is in row
            u (from now until the next call).
        jitter : ndarray of float, shape (N, N)
            ``jitter[v, s]``: how long robot v waits before it transmits s's message
            (``[s, s]``: the original), seconds, >= 0.
        """
        self.provider.call(
            "flood_send",
            self._id,
            *(np.asarray(a) for a in (buffer, offsets, senders, links_indptr, links_indices)),
            np.asarray(jitter, dtype=np.float64),
        )

    def run_until(self, ns3_time: float) -> None:
        """Run ns-3 until ``ns3_time`` (its own clock, seconds); the robots stay where the
        provider placed them."""
        until = float(ns3_time) + self.provider.start_time
        self.provider.call("step", round(ns3_time * 1e9), None, until=until)

    def drain(self) -> tuple[PacketReceptions, PacketTransmissions]:
        """The receptions and transmissions since the last call (and forget them)."""
        e = self.provider.call("flood_drain", self._id)
        size = e["rx_size"]
        rx = PacketReceptions(
            receiver=e["rx_receiver"],
            transmitter=e["rx_transmitter"],
            sender=e["rx_sender"],
            hops=e["rx_hops"],
            time=e["rx_time"],
            size=size,
            payload=e["rx_payload"],
            offsets=np.concatenate([[0], np.cumsum(size)]).astype(np.int64),
        )
        tx = PacketTransmissions(
            node=e["tx_node"],
            sender=e["tx_sender"],
            relay=e["tx_relay"].astype(bool),
            size=e["tx_size"],
            time=e["tx_time"],
        )
        return rx, tx
