"""The ``olsr`` neighbourhood provider: each robot's N_i(h) from its own OLSR routing table."""

from __future__ import annotations

import copy

import numpy as np

from swarmgames.network.links import link_graph
from swarmgames.network.olsr.engine import OlsrEngine
from swarmgames.network.olsr.traffic import ControlTraffic
from swarmgames.network.parameters import OlsrParameters, RadioParameters
from swarmgames.network.propagation import channel_model
from swarmgames.network.provider import NetworkState, check_state
from swarmgames.network.validation import check_positions, check_time
from swarmgames.rng import as_generator
from swarmgames.topology import TopologySnapshot

__all__ = ["OlsrProvider"]


class OlsrProvider:
    """Neighbourhoods read from a simulated OLSR network (RFC 3626 as ns-3 runs it).

    Parameters
    ----------
    n_robots : int
        Number of robots.
    radio : RadioParameters, optional
        Propagation and reception (default: ns-3 defaults, range 368.84 m).
    olsr : OlsrParameters, optional
        OLSR timing (default: ns-3 defaults).
    hello_only : bool, default False
        Send no TC messages: routing tables then hold at most 2 hops, which is all N_i(h) needs
        for h <= 2 and makes 10 000 robots affordable.
    seed : int, Generator or None
        Seed of the message jitter (and of shadowing / fading draws).
    shadowing_key : int, optional
        Key of the static per-pair shadowing field (see
        :func:`~swarmgames.network.propagation.pair_gaussians`); providers given the same key
        see the same channel. Default: drawn from ``seed`` when shadowing is on.

    Raises
    ------
    ValueError
        If ``n_robots < 1`` or ``olsr.max_jitter_s >= olsr.hello_interval_s``.

    Examples
    --------
    >>> p = OlsrProvider(3)
    >>> _ = p.reset(np.array([[0.0, 0, 0], [300, 0, 0], [600, 0, 0]]))
    >>> snap = p.advance(10.0, np.array([[0.0, 0, 0], [300, 0, 0], [600, 0, 0]]))
    >>> snap.hop_matrix()[0].tolist()
    [0, 1, 2]
    """

    name = "olsr"

    def __init__(
        self,
        n_robots: int,
        radio: RadioParameters | None = None,
        olsr: OlsrParameters | None = None,
        hello_only: bool = False,
        seed: int | np.random.Generator | None = None,
        shadowing_key: int | None = None,
    ) -> None:
        if int(n_robots) < 1:
            raise ValueError(f"n_robots must be >= 1 (got {n_robots})")
        self.n_robots = int(n_robots)
        self.olsr = olsr or OlsrParameters()
        if self.olsr.max_jitter_s >= self.olsr.hello_interval_s:
            # Each HELLO round must be on the air before the next is built (ns-3: jitter is a
            # quarter of the HELLO interval).
            raise ValueError(
                "max_jitter_s must be < hello_interval_s "
                f"(got {self.olsr.max_jitter_s} >= {self.olsr.hello_interval_s})"
            )
        self.hello_only = bool(hello_only)
        self._rng = as_generator(seed)
        self.model = channel_model(radio or RadioParameters(), self._rng, shadowing_key)
        self._engine: OlsrEngine | None = None
        self._time = 0.0

    @property
    def time(self) -> float:
        """Current simulated time, seconds."""
        return self._time

    @property
    def engine(self) -> OlsrEngine:
        """The underlying OLSR engine (after :meth:`reset`)."""
        if self._engine is None:
            raise RuntimeError("call reset(positions) before using the network")
        return self._engine

    def reset(self, positions: np.ndarray, start_time: float = 0.0) -> TopologySnapshot:
        """Start every node's OLSR at ``start_time`` with empty tables."""
        check_positions(positions, self.n_robots)
        self._engine = OlsrEngine(
            self.n_robots, self.olsr, self._rng, self.hello_only, float(start_time)
        )
        self._time = float(start_time)
        return self.snapshot()

    def advance(self, to_time: float, positions: np.ndarray) -> TopologySnapshot:
        """Run OLSR until ``to_time`` with robots held at ``positions``."""
        self.step(to_time, positions)
        return self.snapshot()

    def step(self, to_time: float, positions: np.ndarray) -> None:
        """Like :meth:`advance` but without building a snapshot (cheaper between samples)."""
        pos = check_positions(positions, self.n_robots)
        t = check_time(to_time, self._time)
        graph = link_graph(pos, self.model, self._rng)
        self.engine.run_until(t, graph)
        self._time = t

    def snapshot(self) -> TopologySnapshot:
        """Every robot's routing table now."""
        owner, dest, hops, nxt = self.engine.routes(self._time)
        return TopologySnapshot(self._time, self.n_robots, owner, dest, hops, nxt)

    def state(self) -> NetworkState:
        """A copy of everything OLSR will do next: every node's repositories, the messages on
        the air, the timers, the traffic counters and the random state (jitter, fading).

        Examples
        --------
        >>> line = np.array([[0.0, 0, 0], [300, 0, 0], [600, 0, 0]])
        >>> p = OlsrProvider(3, seed=0)
        >>> _ = p.reset(line)
        >>> saved = p.state()
        >>> a = p.advance(20.0, line)
        >>> p.restore(saved)
        >>> b = p.advance(20.0, line)
        >>> bool((a.hops == b.hops).all() and (a.dest == b.dest).all())
        True
        """
        engine = None if self._engine is None else self._engine.state()
        rng = copy.deepcopy(self._rng.bit_generator.state)
        return NetworkState(self.name, self.n_robots, self._time, rng, engine)

    def restore(self, state: NetworkState) -> None:
        """Continue from ``state`` (taken by :meth:`state` of a provider like this one)."""
        check_state(self, state)
        self._rng.bit_generator.state = copy.deepcopy(state.rng)
        self._time = float(state.time)
        if state.data is None:
            self._engine = None
            return
        engine = OlsrEngine(self.n_robots, self.olsr, self._rng, self.hello_only, self._time)
        engine.restore(state.data)
        self._engine = engine

    def control_traffic(self) -> ControlTraffic:
        """OLSR's own messages and bytes, per robot, since the previous call (or ``reset``).

        Counts the HELLOs each robot sent, the TCs it originated and the TCs it forwarded as
        an MPR, each when it went on the air, with RFC 3626 sizes (:mod:`~.wire`); the counters
        then restart from zero. Reading them changes nothing in the network: the tables are the
        same whether or not this is called. Only this provider has the method; the other
        built-in providers send no control traffic (callers use ``getattr``).

        Returns
        -------
        ControlTraffic
            Read-only ``(N,)`` int64 arrays over ``(since, until]``, ``until`` = :attr:`time`.

        Notes
        -----
        The network layer cannot tell a robot the simulation has silenced (moved out of range)
        from one that is out of range: both still send HELLOs here, and a caller that knows a
        robot's radio is off should not charge it.

        Examples
        --------
        >>> line = np.array([[0.0, 0, 0], [300, 0, 0], [600, 0, 0]])
        >>> p = OlsrProvider(3, seed=0)
        >>> _ = p.reset(line)
        >>> p.step(30.0, line)
        >>> p.control_traffic().hello_sent.tolist()
        [15, 15, 15]
        """
        return self.engine.take_control_traffic()
