"""The ``ns3`` neighbourhood provider: OLSR routing tables from the real ns-3 simulator.

Each robot is an ns-3 node with one ad-hoc 802.11a interface, the configured propagation loss
and OLSR (ns-3's ``olsr`` module) as its routing protocol. Positions are set between simulator
chunks (``Simulator.Stop(dt); Simulator.Run()``) and the hop counts are read from every node's
``olsr::RoutingProtocol::GetRoutingTableEntries()``: the same view the paper's ROSNS3 bridge sent
to its controllers.

The radio, as the built-in ``olsr`` model assumes it (docs/reference.md sections 2 and 4):

* 802.11a, constant rate 6 Mbit/s for data and control (OLSR broadcasts go at 6 Mbit/s);
* transmit power ``radio.tx_power_dbm`` (16.0206 dBm by default);
* path loss, chained in this order on a ``YansWifiChannel``:

  - Friis, :math:`P_r = P_t - 20\\log_{10}(4\\pi d f / c) - 10\\log_{10} L`
    (``FriisPropagationLossModel`` with ``Frequency``, ``SystemLoss``, ``MinLoss``), or
    log-distance, :math:`P_r = P_t - L_0 - 10 n \\log_{10}(d / d_0)`
    (``LogDistancePropagationLossModel``);
  - log-normal shadowing, one :math:`\\mathcal{N}(0, \\sigma^2)` dB loss per unordered pair of
    robots, drawn from the provider's numpy Generator at ``reset`` and fixed for the run
    (``MatrixPropagationLossModel``, symmetric);
  - Nakagami-m fading, a fresh draw per frame (``NakagamiPropagationLossModel`` with
    ``m0 = m1 = m2 = radio.nakagami_m``);

* a frame is received when its power reaches ``radio.rx_threshold_dbm`` (the preamble
  detection model's ``MinimumRssi``, -82 dBm by default; with Friis at 5.15 GHz that is a hard
  range of 368.84 m).

OLSR runs with ns-3's defaults but the configured HELLO and TC intervals and willingness. ns-3
derives its other timers from the intervals (jitter ``hello / 4``, neighbour hold
``3 hello``, topology hold ``3 tc``, duplicate hold 30 s) and always sends TCs; configurations
that ns-3 cannot express raise :class:`~swarmgames.errors.ConfigError` rather than being
silently ignored.

ns-3 has one simulator per process. A provider owns it from its ``reset`` until another
provider's ``reset`` (``Simulator.Destroy`` and ``Ipv4AddressGenerator.Reset`` run between
scenarios, so one process can run many of them and pay the import once); using a provider whose
simulator was taken over raises ``RuntimeError``.

References
----------
.. [1] ns-3 3.44 model library, "Optimized Link State Routing (OLSR)" and "Wi-Fi" chapters.
.. [2] RFC 3626, "Optimized Link State Routing Protocol (OLSR)", section 18 (timers).
.. [3] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop: ns-3 with OLSR, Friis, 802.11a, 16.02 dBm.
"""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np

from swarmgames.errors import ConfigError
from swarmgames.network.ns3_import import load_ns3, quiet_stderr
from swarmgames.network.parameters import OlsrParameters, RadioParameters
from swarmgames.network.propagation import new_shadowing_key, pair_gaussians
from swarmgames.network.provider import NetworkState, SnapshotUnsupported
from swarmgames.network.validation import check_positions, check_time
from swarmgames.rng import as_generator
from swarmgames.topology import TopologySnapshot

__all__ = ["Ns3Provider", "check_ns3_config"]

#: ns-3's fixed duplicate-set hold time, seconds (``OLSR_DUP_HOLD_TIME``).
NS3_DUPLICATE_HOLD_S = 30.0

_WILLINGNESS = {0: "never", 1: "low", 3: "default", 6: "high", 7: "always"}

# ns-3 keeps one simulator per process: the token of the provider that built the current one.
_tokens = itertools.count(1)
_owner: list[int] = [0]


def check_ns3_config(olsr: OlsrParameters) -> None:
    """Raise :class:`ConfigError` for OLSR settings that ns-3's OLSR cannot reproduce.

    ns-3 3.44 derives its OLSR timers from the emission intervals (``olsr-routing-protocol.cc``:
    ``OLSR_MAXJITTER = hello / 4``, ``OLSR_NEIGHB_HOLD_TIME = 3 hello``,
    ``OLSR_TOP_HOLD_TIME = 3 tc``, ``OLSR_DUP_HOLD_TIME = 30 s``) and always sends TCs.

    Parameters
    ----------
    olsr : OlsrParameters
        The OLSR timing asked for; the messages name the fields as ``network.olsr.<field>``,
        the configuration they come from.

    Raises
    ------
    ConfigError
        Listing every field that ns-3 would not honour.
    """
    o = olsr
    derived = (
        ("max_jitter_s", o.max_jitter_s, o.hello_interval_s / 4, "hello_interval_s / 4"),
        ("neighbour_hold_s", o.neighbour_hold_s, 3 * o.hello_interval_s, "3 × hello_interval_s"),
        ("topology_hold_s", o.topology_hold_s, 3 * o.tc_interval_s, "3 × tc_interval_s"),
        ("duplicate_hold_s", o.duplicate_hold_s, NS3_DUPLICATE_HOLD_S, "30 s"),
    )
    problems = [
        f"network.olsr.{name}: must equal {rule} = {want:g} for the ns3 backend, which derives "
        f"it (got {got:g})"
        for name, got, want, rule in derived
        if not math.isclose(got, want, rel_tol=1e-9, abs_tol=1e-12)
    ]
    if o.hello_only is True:
        problems.append(
            "network.olsr.hello_only: must be 'auto' or false for the ns3 backend, which always "
            "sends TCs (got True)"
        )
    if problems:
        head = problems[0] if len(problems) == 1 else f"{len(problems)} problems"
        msg = f"invalid configuration for the ns3 backend: {head}"
        if len(problems) > 1:
            msg += "\n  " + "\n  ".join(problems)
        raise ConfigError(msg, problems)


def _assign_streams(wifi, devices, channel, stack, olsr_helper, nodes) -> int:
    """Give every random variable of the scenario a fixed ns-3 stream number, from 0 up.

    Without this, ns-3 numbers the streams of its random variables in the order they are
    created, from a counter that ``Simulator::Destroy`` does not reset: the second scenario of
    a process then draws other OLSR jitter (and fading) than the first, even with the same run
    number. Streams are assigned in this order, which a plain ns-3 program must follow to
    reproduce a run: Wi-Fi devices (``WifiHelper::AssignStreams``: PHY, MAC back-off, station
    manager), the channel's loss chain (``YansWifiChannel::AssignStreams``: Nakagami fading),
    the IP stacks (``InternetStackHelper::AssignStreams``: ARP jitter) and OLSR
    (``OlsrHelper::AssignStreams``: HELLO, TC and forwarding jitter, ``JITTER`` in
    ``olsr-routing-protocol.cc``).

    Returns the number of streams used.

    References
    ----------
    .. [1] ns-3 3.44 manual, "Random Variables": "Setting the stream number" and
       ``AssignStreams``.
    """
    stream = wifi.AssignStreams(devices, 0)
    stream += channel.AssignStreams(stream)
    stream += stack.AssignStreams(nodes, stream)
    return stream + olsr_helper.AssignStreams(nodes, stream)


class Ns3Provider:
    """Neighbourhoods from ns-3's OLSR routing tables (a :class:`NeighbourhoodProvider`).

    Parameters
    ----------
    n_robots : int, optional
        Number of robots; if given, ``reset`` checks the positions against it.
    radio : RadioParameters, optional
        Propagation and reception (default: ns-3 defaults, as in the paper).
    olsr : OlsrParameters, optional
        OLSR timing (default: ns-3 defaults); see :func:`check_ns3_config`.
    seed : int, numpy.random.Generator or None
        Source of every random choice: each ``reset`` draws ns-3's run number (OLSR jitter,
        Nakagami fading, redrawn per packet by ns-3) from it; the static shadowing field's key
        is drawn once, at construction. Equal seeds give equal runs.
    run : int, optional
        Use this ns-3 run number (``RngSeedManager.SetRun``, with seed 1) at every ``reset``
        instead of drawing one. Every random variable gets a fixed stream number (see
        :func:`_assign_streams`), so a run is the same in every scenario of a process and
        in a plain ns-3 program that assigns its streams in the same order.
    shadowing_key : int, optional
        Key of the static per-pair shadowing field (see
        :func:`~swarmgames.network.propagation.pair_gaussians`); providers given the same key
        see the same channel. Default: drawn from ``seed`` when shadowing is on.

    Raises
    ------
    BackendUnavailableError
        If the ``ns3`` package is not installed (``pip install 'swarmgames[ns3]'``).
    ConfigError
        If ``olsr`` asks for OLSR timers that ns-3 cannot reproduce.

    Notes
    -----
    The first provider of a process imports ns-3 (5-18 s, about 665 MB); later ones reuse it.
    Hop counts are those of each node's own table: unreachable destinations have no entry.

    Examples
    --------
    >>> import numpy as np
    >>> from swarmgames.network.ns3_backend import Ns3Provider
    >>> positions = np.array([[0.0, 0, 0], [300, 0, 0], [600, 0, 0]])
    >>> net = Ns3Provider(seed=1)  # doctest: +SKIP
    >>> _ = net.reset(positions)  # doctest: +SKIP
    >>> net.advance(30.0, positions).hop_matrix()[0].tolist()  # doctest: +SKIP
    [0, 1, 2]
    """

    name = "ns3"

    def __init__(
        self,
        n_robots: int | None = None,
        radio: RadioParameters | None = None,
        olsr: OlsrParameters | None = None,
        seed: int | np.random.Generator | None = None,
        *,
        run: int | None = None,
        shadowing_key: int | None = None,
    ) -> None:
        self.radio = RadioParameters() if radio is None else radio
        self.olsr = OlsrParameters() if olsr is None else olsr
        check_ns3_config(self.olsr)
        if n_robots is not None and int(n_robots) < 1:
            raise ValueError(f"n_robots must be >= 1 (got {n_robots})")
        self.n_robots = None if n_robots is None else int(n_robots)
        if run is not None and not (isinstance(run, (int, np.integer)) and run >= 1):
            raise ValueError(f"run must be an integer >= 1 (got {run!r})")
        self._run = None if run is None else int(run)
        self._rng = as_generator(seed)
        self._shadowing_key = shadowing_key
        if self.radio.shadowing_sigma_db > 0 and shadowing_key is None:
            self._shadowing_key = new_shadowing_key(self._rng)
        self._ns = load_ns3()
        self._token = next(_tokens)
        self._n = 0
        self._offset = self._time = 0.0
        self._mobility: list[Any] = []
        self._routing: list[Any] = []
        self._addresses = np.empty(0, dtype=np.int64)
        self.run_number: int | None = None

    def __repr__(self) -> str:
        return f"Ns3Provider(n_robots={self._n or self.n_robots}, run={self.run_number})"

    # -- NeighbourhoodProvider -----------------------------------------------------------------

    @property
    def time(self) -> float:
        """Current simulated time, in seconds (ns-3's clock runs from 0 at ``start_time``)."""
        return self._time

    def reset(self, positions: np.ndarray, start_time: float = 0.0) -> TopologySnapshot:
        """Build a fresh ns-3 scenario with robots at ``positions`` (shape (N, 3), metres).

        Destroys any previous scenario of this process (of this or another provider).
        Returns the (empty) routing tables at ``start_time``.
        """
        p = check_positions(positions, self.n_robots)
        if not math.isfinite(start_time):
            raise ValueError(f"start_time must be finite (got {start_time})")
        with quiet_stderr():
            self._build(p)
        self._offset = self._time = float(start_time)
        return self.snapshot()

    def advance(self, to_time: float, positions: np.ndarray) -> TopologySnapshot:
        """Run ns-3 until ``to_time`` with robots held at ``positions`` and return every
        robot's routing table at ``to_time``."""
        self.step(to_time, positions)
        return self.snapshot()

    # -- finer-grained control -----------------------------------------------------------------

    def step(self, to_time: float, positions: np.ndarray) -> None:
        """Like :meth:`advance` without reading the tables (cheaper for fine mobility steps)."""
        if not self._n:
            raise RuntimeError("call reset(positions) before advancing the ns3 provider")
        self._check_owner()
        to_time = check_time(to_time, self._time - 1e-9)
        p = check_positions(positions, self._n)
        ns = self._ns
        self._place(p)
        stop_ns = round((to_time - self._offset) * 1e9)
        delay = stop_ns - ns.Simulator.Now().GetNanoSeconds()
        if delay > 0:
            with quiet_stderr():
                ns.Simulator.Stop(ns.NanoSeconds(delay))
                ns.Simulator.Run()
        self._time = max(self._time, float(to_time))

    def snapshot(self) -> TopologySnapshot:
        """Every robot's current OLSR routing table as a :class:`TopologySnapshot`."""
        self._check_owner()
        owner, dest, nxt, hops = [], [], [], []
        for i, proto in enumerate(self._routing):
            for e in proto.GetRoutingTableEntries():
                owner.append(i)
                dest.append(e.destAddr.Get())
                nxt.append(e.nextAddr.Get())
                hops.append(e.distance)
        dest_i = self._index(np.asarray(dest, dtype=np.int64))
        next_i = self._index(np.asarray(nxt, dtype=np.int64))
        keep = (dest_i >= 0) & (dest_i != np.asarray(owner, dtype=np.int64))
        return TopologySnapshot(
            time=self.time,
            n_robots=self._n,
            owner=np.asarray(owner, dtype=np.int32)[keep],
            dest=dest_i[keep],
            hops=np.asarray(hops, dtype=np.int16)[keep],
            next_hop=next_i[keep],
        )

    def state(self) -> NetworkState:
        """Not available: ns-3 cannot snapshot a running simulator (its event queue, sockets
        and timers live in C++), so a run on ns-3 cannot be resumed or planned ahead.

        Raises
        ------
        SnapshotUnsupported
            Always.
        """
        raise SnapshotUnsupported(
            "the ns3 network cannot snapshot its state (ns-3 has no simulator snapshot): a run "
            "on it is kept stage by stage but cannot be resumed, and cannot be planned ahead"
        )

    def restore(self, state: NetworkState) -> None:
        """Not available (see :meth:`state`)."""
        self.state()

    @property
    def nodes(self) -> Any:
        """The ns-3 ``NodeContainer`` of the current scenario (robot i is node i), for the
        applications that run on the robots (:mod:`swarmgames.network.ns3_packets`)."""
        self._check_owner()
        return self._nodes

    def close(self) -> None:
        """Destroy this provider's ns-3 scenario (a no-op if another provider took over)."""
        if self._n and _owner[0] == self._token:
            with quiet_stderr():
                self._ns.Simulator.Destroy()
            _owner[0] = 0
        self._n = 0
        self._mobility, self._routing = [], []

    def __enter__(self) -> Ns3Provider:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- internals -----------------------------------------------------------------------------

    def _check_owner(self) -> None:
        if _owner[0] != self._token:
            raise RuntimeError(
                "this ns3 provider's scenario was destroyed (ns-3 runs one scenario per "
                "process and another provider called reset, or close was called); call reset"
            )

    def _index(self, addr: np.ndarray) -> np.ndarray:
        pos = np.searchsorted(self._addresses, addr)
        pos = np.minimum(pos, self._addresses.size - 1)
        hit = self._addresses[pos] == addr
        return np.where(hit, self._order[pos], -1).astype(np.int32)

    def _place(self, p: np.ndarray) -> None:
        vec = self._ns.Vector
        for mob, (x, y, z) in zip(self._mobility, p.tolist(), strict=True):
            mob.SetPosition(vec(x, y, z))

    def _build(self, p: np.ndarray) -> None:
        ns = self._ns
        radio, olsr = self.radio, self.olsr
        n = p.shape[0]
        ns.Simulator.Destroy()
        ns.Ipv4AddressGenerator.Reset()
        _owner[0] = self._token
        self.run_number = self._run or int(self._rng.integers(1, 2**31))
        ns.RngSeedManager.SetSeed(1)
        ns.RngSeedManager.SetRun(self.run_number)

        nodes = ns.NodeContainer()
        nodes.Create(n)
        mobility = ns.MobilityHelper()
        mobility.SetMobilityModel("ns3::ConstantPositionMobilityModel")
        mobility.Install(nodes)
        self._mobility = [nodes.Get(i).GetObject[ns.MobilityModel]() for i in range(n)]
        self._place(p)

        wifi = ns.WifiHelper()
        wifi.SetStandard(ns.WIFI_STANDARD_80211a)
        rate = ns.StringValue("OfdmRate6Mbps")
        wifi.SetRemoteStationManager(
            "ns3::ConstantRateWifiManager", "DataMode", rate, "ControlMode", rate
        )
        phy = ns.YansWifiPhyHelper()
        channel = self._channel(radio)
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
        self._routing = [nodes.Get(i).GetObject[ns.olsr.RoutingProtocol]() for i in range(n)]
        _assign_streams(wifi, devices, channel, stack, helper, nodes)

        addr = np.array([interfaces.GetAddress(i).Get() for i in range(n)], dtype=np.int64)
        self._order = np.argsort(addr).astype(np.int32)
        self._addresses = addr[self._order]
        self._n = n
        self._nodes = nodes

    def _channel(self, radio: RadioParameters) -> Any:
        ns = self._ns
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
            n = len(self._mobility)
            iu, ju = np.triu_indices(n, k=1)
            # The same static per-pair field as the built-in providers with the same key.
            draws = radio.shadowing_sigma_db * pair_gaussians(iu, ju, self._shadowing_key)
            for i, j, db in zip(iu.tolist(), ju.tolist(), draws.tolist(), strict=True):
                matrix.SetLoss(self._mobility[i], self._mobility[j], db, True)
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
