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

ns-3 runs in a child process (:mod:`swarmgames.network.ns3_process`, built by
:mod:`swarmgames.network.ns3_worker`), so that an abort inside ns-3 raises
:class:`~swarmgames.errors.Ns3CrashError` here, one line with ns-3's reason, the run number and
the simulated time, instead of ending the caller. That process has one simulator. A provider
owns it from its ``reset`` until another provider's ``reset`` (``Simulator.Destroy`` and
``Ipv4AddressGenerator.Reset`` run between scenarios, so one process can run many of them and
pay the import once); using a provider whose simulator was taken over raises
``RuntimeError``.

References
----------
.. [1] ns-3 3.44 model library, "Optimized Link State Routing (OLSR)" and "Wi-Fi" chapters.
.. [2] RFC 3626, "Optimized Link State Routing Protocol (OLSR)", section 18 (timers).
.. [3] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop: ns-3 with OLSR, Friis, 802.11a, 16.02 dBm.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from swarmgames.errors import ConfigError, Ns3CrashError
from swarmgames.network.ns3_process import Ns3ProcessDied, shared_process
from swarmgames.network.parameters import OlsrParameters, RadioParameters
from swarmgames.network.propagation import new_shadowing_key
from swarmgames.network.provider import NetworkState, SnapshotUnsupported
from swarmgames.network.validation import check_positions, check_time
from swarmgames.rng import as_generator
from swarmgames.topology import TopologySnapshot

__all__ = ["Ns3Provider", "check_ns3_config"]

#: ns-3's fixed duplicate-set hold time, seconds (``OLSR_DUP_HOLD_TIME``).
NS3_DUPLICATE_HOLD_S = 30.0


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
        :func:`swarmgames.network.ns3_worker._assign_streams`), so a run is the same in every
        scenario of a process and in a plain ns-3 program that assigns its streams in the same
        order.
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
    Ns3CrashError
        From any method that runs ns-3, if ns-3 aborts (see :meth:`call`).

    Notes
    -----
    The first provider of a process starts the ns-3 process, which imports ns-3 (5-18 s,
    about 665 MB); later ones reuse it, and one after a crash starts a fresh one. Hop counts
    are those of each node's own table: unreachable destinations have no entry.

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
        self._process = shared_process()
        self._scenario = 0  # the scenario's id in the ns-3 process; 0: none
        self._n = 0
        self._offset = self._time = 0.0
        self.run_number: int | None = None

    def __repr__(self) -> str:
        return f"Ns3Provider(n_robots={self._n or self.n_robots}, run={self.run_number})"

    # -- NeighbourhoodProvider -----------------------------------------------------------------

    @property
    def time(self) -> float:
        """Current simulated time, in seconds (ns-3's clock runs from 0 at ``start_time``)."""
        return self._time

    @property
    def start_time(self) -> float:
        """The time of the last ``reset``, seconds: ns-3's clock reads 0 then."""
        return self._offset

    def reset(self, positions: np.ndarray, start_time: float = 0.0) -> TopologySnapshot:
        """Build a fresh ns-3 scenario with robots at ``positions`` (shape (N, 3), metres).

        Destroys any previous scenario of this process (of this or another provider).
        Returns the (empty) routing tables at ``start_time``.
        """
        p = check_positions(positions, self.n_robots)
        if not math.isfinite(start_time):
            raise ValueError(f"start_time must be finite (got {start_time})")
        if not self._process.alive:  # the last scenario took its process down
            self._process = shared_process()
        self.run_number = self._run or int(self._rng.integers(1, 2**31))
        self._offset = self._time = float(start_time)
        self._scenario = 0
        self._scenario = self.call(
            "build",
            p,
            dataclasses.asdict(self.radio),
            dataclasses.asdict(self.olsr),
            self.run_number,
            self._shadowing_key,
        )
        self._n = p.shape[0]
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
        to_time = check_time(to_time, self._time - 1e-9)
        p = check_positions(positions, self._n)
        self.call("step", round((to_time - self._offset) * 1e9), p, until=float(to_time))
        self._time = max(self._time, float(to_time))

    def snapshot(self) -> TopologySnapshot:
        """Every robot's current OLSR routing table as a :class:`TopologySnapshot`.

        Entries whose destination is no robot, or the owner itself (ns-3 routes a node to
        itself through a stale topology tuple), are left out; :meth:`routing_entries` has
        them all."""
        owner, dest, next_hop, hops = self.routing_entries()
        keep = (dest >= 0) & (dest != owner)
        return TopologySnapshot(
            time=self.time,
            n_robots=self._n,
            owner=owner[keep],
            dest=dest[keep],
            hops=hops[keep],
            next_hop=next_hop[keep],
        )

    def routing_entries(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Every entry of every node's ns-3 OLSR routing table, as ns-3 holds it.

        Returns
        -------
        owner, dest, next_hop : ndarray of int32, shape (E,)
            The table's node, the destination and the next hop, as robot indices (-1 for an
            address that is no robot's).
        hops : ndarray of int16, shape (E,)
            The entry's distance.
        """
        if not self._n:
            raise RuntimeError("call reset(positions) before reading the ns3 provider's tables")
        return self.call("tables")

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
    def scenario(self) -> int:
        """The id of this provider's scenario in its ns-3 process (0: none), which the
        applications on the robots (:mod:`swarmgames.network.ns3_packets`) attach to."""
        return self._scenario

    def call(self, op: str, *args: Any, until: float | None = None) -> Any:
        """Send request ``op`` about this provider's scenario to the ns-3 process
        (:mod:`swarmgames.network.ns3_worker`), for this provider and the applications that
        run on its robots.

        Parameters
        ----------
        op : str
            The request; the scenario's id goes first among its arguments, except for
            ``build``.
        *args
            Its other arguments.
        until : float, optional
            The time, in this provider's clock, that the request runs ns-3 to; named when
            ns-3 fails without a time stamp of its own.

        Raises
        ------
        Ns3CrashError
            If ns-3 ended its process (an ``NS_ASSERT``, ``NS_FATAL_ERROR`` or a crash): one
            line with ns-3's reason, this provider's run number and the simulated time.
        RuntimeError
            If this provider's scenario was destroyed (another provider's ``reset``, or
            ``close``) or never built.
        """
        if op != "build":
            if not self._scenario:
                raise RuntimeError(
                    "this ns3 provider's scenario was destroyed or never built; call reset"
                )
            args = (self._scenario, *args)
        try:
            return self._process.call(op, *args)
        except Ns3ProcessDied as died:
            self._scenario, self._n = 0, 0
            raise self._crash(died, until) from None

    def close(self) -> None:
        """Destroy this provider's ns-3 scenario (a no-op if another provider took over)."""
        if self._scenario and self._process.alive:
            self._process.call("destroy", self._scenario)
        self._scenario, self._n = 0, 0

    def __enter__(self) -> Ns3Provider:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- internals -----------------------------------------------------------------------------

    def _crash(self, died: Ns3ProcessDied, until: float | None) -> Ns3CrashError:
        """The one-line error of a dead ns-3 process, in this provider's run and clock."""
        if died.ns3_time is not None:
            t, when = died.ns3_time + self._offset, f"t = {died.ns3_time + self._offset:.6g} s"
        elif until is not None:
            t, when = until, f"between t = {self._time:g} s and {until:g} s"
        else:
            t, when = None, f"after t = {self._time:g} s"
        node = "" if died.node is None or died.node < 0 else f", node {died.node}"
        message = (
            f"ns-3 aborted in its run {self.run_number} at {when}{node}: {died.reason} "
            '(docs/ns3.md, "Known ns-3 faults")'
        )
        return Ns3CrashError(message, died.reason, self.run_number, t, died.exit_code)
