"""The ns-3 process: builds and runs ns-3 scenarios for its parent (:mod:`.ns3_process`).

Run as ``python -m swarmgames.network.ns3_worker FD PARENT_PID``: FD is this end of the socket
pair, PARENT_PID the process this one ends with. It answers one request at a time, in order:

=================  =================================================================
request            answer
=================  =================================================================
``hello``          imports ns-3; its version
``build``          a fresh scenario (module docstring of :mod:`.ns3_backend`); its id
``step``           runs the scenario to a time with the robots at given positions
``tables``         every node's OLSR routing table, as arrays of robot indices
``now``            ns-3's clock, seconds
``destroy``        ``Simulator::Destroy``
``flood_*``        the state-message sockets of :mod:`.ns3_packets`
``olsr_*``         the OLSR counters of :mod:`.ns3_olsr_traffic`
=================  =================================================================

An ns-3 abort ends this process; the parent reads why from its standard error.

References
----------
.. [1] ns-3 3.44 model library, "Optimized Link State Routing (OLSR)" and "Wi-Fi" chapters.
.. [2] ns-3 3.44 manual, "Random Variables": "Setting the stream number" and
   ``AssignStreams``.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from swarmgames.lifetime import end_with
from swarmgames.network import ns3_olsr_traffic, ns3_packets
from swarmgames.network.ns3_import import load_ns3
from swarmgames.network.parameters import OlsrParameters, RadioParameters
from swarmgames.network.propagation import pair_gaussians

__all__ = ["Ns3Server", "main"]

_WILLINGNESS = {0: "never", 1: "low", 3: "default", 6: "high", 7: "always"}


def _assign_streams(wifi, devices, channel, stack, olsr_helper, nodes) -> int:
    """Give every random variable of the scenario a fixed ns-3 stream number, from 0 up.

    Without this, ns-3 numbers the streams of its random variables in the order they are
    created, from a counter that ``Simulator::Destroy`` does not reset: the second scenario of
    a process would then draw other OLSR jitter (and fading) than the first, even with the
    same run number. Streams are assigned in this order, which a plain ns-3 program must
    follow to reproduce a run: Wi-Fi devices (``WifiHelper::AssignStreams``: PHY, MAC
    back-off, station manager), the channel's loss chain (``YansWifiChannel::AssignStreams``:
    Nakagami fading), the IP stacks (``InternetStackHelper::AssignStreams``: ARP jitter) and
    OLSR (``OlsrHelper::AssignStreams``: HELLO, TC and forwarding jitter, ``JITTER`` in
    ``olsr-routing-protocol.cc``).

    Returns the number of streams used.
    """
    stream = wifi.AssignStreams(devices, 0)
    stream += channel.AssignStreams(stream)
    stream += stack.AssignStreams(nodes, stream)
    return stream + olsr_helper.AssignStreams(nodes, stream)


class _Scenario:
    """One ns-3 scenario: nodes at positions, 802.11a, the loss chain and OLSR."""

    def __init__(
        self,
        ns: Any,
        p: np.ndarray,
        radio: RadioParameters,
        olsr: OlsrParameters,
        run: int,
        shadowing_key: int | None,
    ) -> None:
        self.ns = ns
        n = p.shape[0]
        ns.Simulator.Destroy()
        ns.Ipv4AddressGenerator.Reset()
        ns.RngSeedManager.SetSeed(1)
        ns.RngSeedManager.SetRun(run)

        nodes = ns.NodeContainer()
        nodes.Create(n)
        mobility = ns.MobilityHelper()
        mobility.SetMobilityModel("ns3::ConstantPositionMobilityModel")
        mobility.Install(nodes)
        self.mobility = [nodes.Get(i).GetObject[ns.MobilityModel]() for i in range(n)]
        self.place(p)

        wifi = ns.WifiHelper()
        wifi.SetStandard(ns.WIFI_STANDARD_80211a)
        rate = ns.StringValue("OfdmRate6Mbps")
        wifi.SetRemoteStationManager(
            "ns3::ConstantRateWifiManager", "DataMode", rate, "ControlMode", rate
        )
        phy = ns.YansWifiPhyHelper()
        channel = self._channel(radio, shadowing_key)
        phy.SetChannel(channel)
        power = ns.DoubleValue(radio.tx_power_dbm)
        phy.Set("TxPowerStart", power)
        phy.Set("TxPowerEnd", power)
        phy.SetPreambleDetectionModel(
            "ns3::ThresholdPreambleDetectionModel",
            "MinimumRssi",
            ns.DoubleValue(radio.rx_threshold_dbm),
        )
        mac = ns.WifiMacHelper()
        mac.SetType("ns3::AdhocWifiMac")
        devices = wifi.Install(phy, mac, nodes)

        helper = ns.OlsrHelper()
        helper.Set("HelloInterval", ns.TimeValue(ns.Seconds(olsr.hello_interval_s)))
        helper.Set("TcInterval", ns.TimeValue(ns.Seconds(olsr.tc_interval_s)))
        helper.Set("Willingness", ns.StringValue(_WILLINGNESS[olsr.willingness]))
        stack = ns.InternetStackHelper()
        stack.SetRoutingHelper(helper)
        stack.Install(nodes)
        ipv4 = ns.Ipv4AddressHelper()
        ipv4.SetBase(ns.Ipv4Address("10.0.0.0"), ns.Ipv4Mask("255.0.0.0"))
        interfaces = ipv4.Assign(devices)
        self.routing = [nodes.Get(i).GetObject[ns.olsr.RoutingProtocol]() for i in range(n)]
        _assign_streams(wifi, devices, channel, stack, helper, nodes)

        addr = np.array([interfaces.GetAddress(i).Get() for i in range(n)], dtype=np.int64)
        self.order = np.argsort(addr).astype(np.int32)
        self.addresses = addr[self.order]
        self.nodes = nodes

    def place(self, p: np.ndarray) -> None:
        vec = self.ns.Vector
        for mob, (x, y, z) in zip(self.mobility, p.tolist(), strict=True):
            mob.SetPosition(vec(x, y, z))

    def run_to(self, stop_ns: int) -> None:
        """Run the simulator until its clock reads ``stop_ns`` nanoseconds."""
        ns = self.ns
        delay = int(stop_ns) - ns.Simulator.Now().GetNanoSeconds()
        if delay > 0:
            ns.Simulator.Stop(ns.NanoSeconds(delay))
            ns.Simulator.Run()

    def tables(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Every node's routing-table entries: owner, destination and next hop (robot
        indices, -1 for an address that is no robot's) and hops."""
        owner, dest, nxt, hops = [], [], [], []
        for i, proto in enumerate(self.routing):
            for e in proto.GetRoutingTableEntries():
                owner.append(i)
                dest.append(e.destAddr.Get())
                nxt.append(e.nextAddr.Get())
                hops.append(e.distance)
        return (
            np.asarray(owner, dtype=np.int32),
            self._index(np.asarray(dest, dtype=np.int64)),
            self._index(np.asarray(nxt, dtype=np.int64)),
            np.asarray(hops, dtype=np.int16),
        )

    def _index(self, addr: np.ndarray) -> np.ndarray:
        pos = np.searchsorted(self.addresses, addr)
        pos = np.minimum(pos, self.addresses.size - 1)
        hit = self.addresses[pos] == addr
        return np.where(hit, self.order[pos], -1).astype(np.int32)

    def _channel(self, radio: RadioParameters, shadowing_key: int | None) -> Any:
        ns = self.ns
        if radio.loss_model == "friis":
            loss = ns.CreateObject[ns.FriisPropagationLossModel]()
            loss.SetAttribute("Frequency", ns.DoubleValue(radio.frequency_hz))
            loss.SetAttribute("SystemLoss", ns.DoubleValue(radio.system_loss))
            loss.SetAttribute("MinLoss", ns.DoubleValue(radio.min_loss_db))
        else:
            loss = ns.CreateObject[ns.LogDistancePropagationLossModel]()
            loss.SetAttribute("Exponent", ns.DoubleValue(radio.exponent))
            loss.SetAttribute("ReferenceDistance", ns.DoubleValue(radio.reference_distance_m))
            loss.SetAttribute("ReferenceLoss", ns.DoubleValue(radio.reference_loss_db))
        last = loss
        if radio.shadowing_sigma_db > 0:
            matrix = ns.CreateObject[ns.MatrixPropagationLossModel]()
            matrix.SetDefaultLoss(0.0)
            n = len(self.mobility)
            iu, ju = np.triu_indices(n, k=1)
            # The same static per-pair field as the built-in providers with the same key.
            draws = radio.shadowing_sigma_db * pair_gaussians(iu, ju, shadowing_key)
            for i, j, db in zip(iu.tolist(), ju.tolist(), draws.tolist(), strict=True):
                matrix.SetLoss(self.mobility[i], self.mobility[j], db, True)
            last.SetNext(matrix)
            last = matrix
        if radio.nakagami_m is not None:
            fading = ns.CreateObject[ns.NakagamiPropagationLossModel]()
            for k in ("m0", "m1", "m2"):
                fading.SetAttribute(k, ns.DoubleValue(radio.nakagami_m))
            last.SetNext(fading)
        channel = ns.CreateObject[ns.YansWifiChannel]()
        channel.SetPropagationLossModel(loss)
        channel.SetPropagationDelayModel(ns.CreateObject[ns.ConstantSpeedPropagationDelayModel]())
        return channel


class Ns3Server:
    """The requests of the module docstring, on one ns-3 simulator (one scenario at a time)."""

    def __init__(self) -> None:
        self.ns: Any = None
        self.scenario: _Scenario | None = None
        self.scenario_id = 0
        self.floods: dict[int, tuple[int, Any]] = {}
        self.counters: dict[int, tuple[int, Any]] = {}
        self._ids = 0
        self.ops: dict[str, Callable[..., Any]] = {
            "hello": self.hello,
            "build": self.build,
            "step": self.step,
            "tables": self.tables,
            "now": self.now,
            "destroy": self.destroy,
            "flood_open": self.flood_open,
            "flood_send": self.flood_send,
            "flood_drain": self.flood_drain,
            "flood_close": self.flood_close,
            "olsr_open": self.olsr_open,
            "olsr_take": self.olsr_take,
        }

    # -- the simulator ---------------------------------------------------------------------

    def hello(self) -> str:
        from importlib.metadata import version

        self.ns = load_ns3()
        return version("ns3")

    def build(self, positions, radio: dict, olsr: dict, run: int, shadowing_key) -> int:
        self.floods.clear()
        self.counters.clear()
        self.scenario = None
        self.scenario = _Scenario(
            self.ns,
            np.asarray(positions, dtype=np.float64),
            RadioParameters(**radio),
            OlsrParameters(**olsr),
            int(run),
            shadowing_key,
        )
        self.scenario_id = self._next_id()
        return self.scenario_id

    def step(self, scenario: int, stop_ns: int, positions) -> None:
        s = self._scenario(scenario)
        if positions is not None:
            s.place(np.asarray(positions, dtype=np.float64))
        s.run_to(stop_ns)

    def tables(self, scenario: int):
        return self._scenario(scenario).tables()

    def now(self, scenario: int) -> float:
        self._scenario(scenario)
        return float(self.ns.Simulator.Now().GetSeconds())

    def destroy(self, scenario: int) -> None:
        if scenario == self.scenario_id and self.scenario is not None:
            self.floods.clear()
            self.counters.clear()
            self.scenario = None
            self.ns.Simulator.Destroy()

    # -- state messages (ns3_packets) ------------------------------------------------------

    def flood_open(self, scenario: int, ttl: int, port: int) -> tuple[int, int]:
        nodes = self._scenario(scenario).nodes
        try:
            flood = ns3_packets.compiled(self.ns).StateFlood(nodes, int(port), int(ttl))
        except TypeError as exc:  # cppyy reports the C++ exception among the overloads
            if "is taken" not in str(exc):
                raise
            raise RuntimeError(
                f"UDP port {port} is taken on the provider's nodes: close() the StateFlood "
                "that holds it (reset its communication model) first"
            ) from None
        fid = self._next_id()
        self.floods[fid] = (scenario, flood)
        return fid, int(nodes.GetN())

    def flood_send(
        self, scenario: int, fid: int, buffer, offsets, senders, indptr, indices, jitter
    ) -> None:
        ns3_packets.schedule(self._flood(fid), buffer, offsets, senders, indptr, indices, jitter)

    def flood_drain(self, scenario: int, fid: int) -> dict[str, np.ndarray]:
        return ns3_packets.drain_events(self._flood(fid))

    def flood_close(self, scenario: int, fid: int) -> None:
        if fid in self.floods and scenario == self.scenario_id:
            self.floods.pop(fid)[1].Close()

    # -- OLSR counters (ns3_olsr_traffic) --------------------------------------------------

    def olsr_open(self, scenario: int) -> int:
        nodes = self._scenario(scenario).nodes
        cid = self._next_id()
        self.counters[cid] = (scenario, ns3_olsr_traffic.compiled(self.ns).OlsrTxCounter(nodes))
        return cid

    def olsr_take(self, scenario: int, cid: int) -> np.ndarray:
        nodes = self._scenario(scenario).nodes
        if cid not in self.counters:
            raise RuntimeError("the OLSR counters' scenario was destroyed")
        return ns3_olsr_traffic.take_counts(self.counters[cid][1], int(nodes.GetN()))

    # -- internals -------------------------------------------------------------------------

    def _next_id(self) -> int:
        self._ids += 1
        return self._ids

    def _scenario(self, scenario: int) -> _Scenario:
        if self.scenario is None or scenario != self.scenario_id:
            raise RuntimeError(
                "this ns3 provider's scenario was destroyed (ns-3 runs one scenario per "
                "process and another provider called reset, or close was called); call reset"
            )
        return self.scenario

    def _flood(self, fid: int) -> Any:
        if fid not in self.floods or self.floods[fid][0] != self.scenario_id:
            raise RuntimeError("the state-message sockets' scenario was destroyed")
        return self.floods[fid][1]


def serve(conn: Connection, server: Ns3Server) -> None:
    """Answer requests on ``conn`` until the parent closes it."""
    while True:
        try:
            op, args = conn.recv()
        except EOFError:
            return
        handler = server.ops.get(op)
        try:
            if handler is None:
                raise ValueError(f"unknown ns-3 request {op!r}")
            reply = ("ok", handler(*args))
        except Exception as exc:  # sent back by name, raised again in the parent
            reply = ("error", (type(exc).__name__, str(exc)))
        conn.send(reply)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the child process: ``FD PARENT_PID``."""
    fd, parent = (int(a) for a in (sys.argv[1:] if argv is None else argv))
    end_with(parent)
    serve(Connection(fd), Ns3Server())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
