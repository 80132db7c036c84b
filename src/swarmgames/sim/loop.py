"""The stage loop: network, local games, actions, repeated every control period.

One stage at time :math:`t_k = t_{warm} + k\\,\\Delta t`:

1. the network provider is advanced to :math:`t_k` with the robots held at the positions they
   reached (OLSR keeps running between stages, so its tables lag the geometry as in ns-3);
2. every robot reads its neighbourhood :math:`N_i(h)` from its own routing table, and the
   communication model delivers the stage's state messages;
3. the controller turns the stage into a :class:`~swarmgames.game.problem.StageProblem` and
   decides every robot's action (the stage pipeline of :mod:`swarmgames.game.stage`: all
   local games built, evaluated, solved and measured in batches; or a mission's baseline);
4. the mission measures the stage (:meth:`~swarmgames.missions.protocol.Mission.swarm_metrics`)
   and the loop measures the network and the oscillation (:func:`oscillation`);
5. the actions are applied; the new states hold until the next stage.

Ctrl-C (``KeyboardInterrupt``; :func:`swarmgames.run` turns SIGTERM and SIGHUP into it too)
between or during stages stops the loop cleanly: the completed stages are kept and returned
with ``interrupted = True``.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, section II (stage game) and III (ROSNS3 runs
   the network between 1 Hz control ticks).
"""

from __future__ import annotations

import copy
import time
import warnings
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from scipy.sparse import csgraph, csr_array

from swarmgames.arrays import freeze_fields
from swarmgames.errors import ChannelOverloadWarning, PayoffError
from swarmgames.missions.protocol import MissionHooks
from swarmgames.network.hops import hop_statistics
from swarmgames.sim.signals import deferred_interrupts, raise_if_signalled
from swarmgames.topology import TopologySnapshot

__all__ = [
    "LoopState",
    "StageLog",
    "StageLoop",
    "StageRecord",
    "StageView",
    "drive",
    "oscillation",
    "run_stages",
    "swarm_graph_stats",
]


def swarm_graph_stats(snapshot: TopologySnapshot) -> tuple[float, int, int, np.ndarray]:
    """Hop statistics and connectivity of the swarm as its routing tables see it.

    Returns the mean and max hop count over the ordered pairs that can reach each other, the
    number of connected components of the 1-hop links (symmetric neighbours in the tables),
    and those links as undirected edges ``(E, 2)`` with ``i < j``, sorted.

    Notes
    -----
    The hops are breadth-first distances over the tables' 1-hop links (what settled OLSR
    routes, paper Fig. 1's "unreachable pairs left out"), so they do not depend on how far
    the tables themselves reach: OLSR in HELLO-only mode (h <= 2) holds no route longer than
    2 hops, yet the swarm may be 6 hops across. Up to
    :data:`~swarmgames.network.hops.EXACT_UP_TO` robots they are exact all-pairs statistics;
    above, from :data:`~swarmgames.network.hops.SOURCES` evenly spaced sources
    (:func:`~swarmgames.network.hops.hop_statistics`), so that their cost stays linear in N.
    """
    n = snapshot.n_robots
    one = snapshot.hops == 1
    a, b = snapshot.owner[one], snapshot.dest[one]
    lo, hi = np.minimum(a, b).astype(np.int64), np.maximum(a, b).astype(np.int64)
    keys = np.unique(lo * max(n, 1) + hi)  # the same rows as np.unique(..., axis=0), faster
    edges = np.column_stack([keys // max(n, 1), keys % max(n, 1)])
    graph = csr_array((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    n_comp = int(csgraph.connected_components(graph, directed=False)[0])
    mean_h, max_h = hop_statistics(n, edges)
    return mean_h, max_h, n_comp, edges.astype(np.int32)


#: Position change below which a robot is where it was, metres.
SAME_PLACE_M = 1e-6


def oscillation(before: np.ndarray | None, now: np.ndarray, after: np.ndarray) -> float:
    """Share of robots back, after a stage, at the position they held two stages before
    although they had left it: :math:`|p_{k+1} - p_{k-1}| \\le \\epsilon < |p_k - p_{k-1}|`.

    A myopic stage game on a link-keeping mission can cycle: robots alternate between two
    positions for ever. This share is 0 for a swarm that settles or moves on, 1 when every
    robot cycles with period 2. Positions are the first three state columns;
    :math:`\\epsilon` is :data:`SAME_PLACE_M`. 0 at the first stage (``before is None``).
    """
    if before is None or now.shape[0] == 0:
        return 0.0
    left = np.linalg.norm(now[:, :3] - before[:, :3], axis=1) > SAME_PLACE_M
    back = np.linalg.norm(after[:, :3] - before[:, :3], axis=1) <= SAME_PLACE_M
    return float(np.mean(left & back))


@dataclass(frozen=True, eq=False)
class StageRecord:
    """What one completed stage recorded (immutable).

    Attributes
    ----------
    t : float
        Stage time, s.
    actions : ndarray, shape (N,)
        Every robot's action.
    robot : dict of (N,) arrays
        The per-robot columns of ``metrics.csv`` (decision, communication, faults, OLSR
        traffic, the mission's robot metrics).
    swarm : dict of float
        The stage's row of ``swarm.csv`` (without ``t``).
    links : ndarray, shape (E, 2)
        The 1-hop links of the routing tables.
    after : ndarray, shape (N, D)
        The states after the stage.
    wall_s : float
        Wall time of the stage, s.
    """

    t: float
    actions: np.ndarray
    robot: dict[str, np.ndarray]
    swarm: dict[str, float]
    links: np.ndarray
    after: np.ndarray
    wall_s: float

    def __post_init__(self) -> None:
        freeze_fields(self)
        for val in self.robot.values():
            val.flags.writeable = False


@dataclass
class StageLog:
    """Everything recorded by the loop; arrays are stacked over the S completed stages.

    Attributes
    ----------
    times : (S,) stage times, s.  states : (S + 1, N, D) states at each stage and after the
    last one.  actions : (S, N).  per_robot : dict of (S, N) arrays (payoff, neighbours,
    local_regret, global_regret, expost_regret, iterations, converged, solve_ms, integrate_ms,
    refine_sweeps, refine_moves, refine_ms, then the mission's robot metrics).  swarm : dict
    of (S,) arrays (mean_payoff, the mission's metrics, mean_hops, max_hops, components,
    oscillation).  links : list of (E, 2) 1-hop edges per stage.  interrupted : whether
    Ctrl-C stopped the loop.  wall_s : loop time, s.  stage_s : (S,) wall time of each
    stage, s.
    """

    times: np.ndarray
    states: np.ndarray
    actions: np.ndarray
    per_robot: dict[str, np.ndarray]
    swarm: dict[str, np.ndarray]
    links: list[np.ndarray]
    interrupted: bool
    wall_s: float
    stage_s: np.ndarray
    period_s: float = 1.0
    warmup_s: float = 0.0

    @classmethod
    def from_records(
        cls,
        start: np.ndarray,
        records: list[StageRecord],
        *,
        interrupted: bool,
        wall_s: float,
        period_s: float,
        warmup_s: float,
    ) -> StageLog:
        """Stack the records of the completed stages; ``start`` is the states before the
        first."""
        start = np.asarray(start, dtype=float)
        n = start.shape[0]
        per_robot: dict[str, list] = {}
        swarm: dict[str, list] = {}
        for rec in records:
            for name, val in rec.robot.items():
                per_robot.setdefault(name, []).append(val)
            for name, val in rec.swarm.items():
                swarm.setdefault(name, []).append(val)
        return cls(
            times=np.asarray([r.t for r in records], dtype=float),
            states=np.stack([start, *(r.after for r in records)]),
            actions=(
                np.stack([r.actions for r in records])
                if records
                else np.zeros((0, n), dtype=np.int64)
            ),
            per_robot={k: np.stack(v) for k, v in per_robot.items()},
            swarm={k: np.asarray(v) for k, v in swarm.items()},
            links=[r.links for r in records],
            interrupted=bool(interrupted),
            wall_s=float(wall_s),
            stage_s=np.asarray([r.wall_s for r in records], dtype=float),
            period_s=float(period_s),
            warmup_s=float(warmup_s),
        )


#: Per-robot columns of a decision, NaN for a robot that has crashed.
DECISION_COLUMNS = (
    "payoff",
    "local_regret",
    "global_regret",
    "expost_regret",
    "solve_ms",
    "integrate_ms",
    "refine_ms",
)


def _robot_columns(stage, n: int) -> dict[str, np.ndarray]:
    """The per-robot columns of ``metrics.csv`` from a :class:`StageSolution`; times are
    amortised over the robots."""
    return {
        "payoff": stage.payoff,
        "neighbours": stage.neighbours,
        "local_regret": stage.local_regret,
        "global_regret": stage.global_regret,
        "expost_regret": stage.expost_regret,
        "iterations": stage.iterations,
        "converged": stage.converged,
        "solve_ms": np.full(n, 1e3 * stage.solve_s / max(1, n)),
        "integrate_ms": np.full(n, 1e3 * stage.integrate_s / max(1, n)),
        "refine_sweeps": stage.refine_sweeps,
        "refine_moves": stage.refine_moves,
        "refine_ms": np.full(n, 1e3 * stage.refine_s / max(1, n)),
    }


def _nanmax(values: np.ndarray) -> float:
    """The largest finite value, NaN if there is none."""
    finite = np.asarray(values, dtype=float)
    finite = finite[np.isfinite(finite)]
    return float(finite.max()) if finite.size else float("nan")


def _nanmean(values: np.ndarray) -> float:
    """Mean of the finite values (NaN when there are none)."""
    ok = np.isfinite(values)
    return float(values[ok].mean()) if ok.any() else float("nan")


@dataclass(frozen=True, eq=False)
class StageView:
    """A stage up to the decision (:meth:`StageLoop.observe`).

    Attributes
    ----------
    t : float
        Stage time, s.
    states : ndarray, shape (N, D)
        The true states.
    snapshot : TopologySnapshot
        The routing tables.
    messages : Inbox
        What every robot holds of its neighbourhood at the decision (the communication
        model's messages; exact ones with ideal delivery).
    heard : CommsStats
        The exchange's measures.
    alive, radio : ndarray of bool, shape (N,)
        Robots not crashed; robots with a working radio.
    started : float
        ``time.perf_counter()`` when the stage began.
    """

    t: float
    states: np.ndarray
    snapshot: TopologySnapshot
    messages: Any
    heard: Any
    alive: np.ndarray
    radio: np.ndarray
    started: float

    @property
    def problem_fields(self) -> tuple:
        """``(t, snapshot, states, messages)``: what a controller's stage problem is built
        from (:meth:`~swarmgames.sim.controllers.Controller.problem`)."""
        return self.t, self.snapshot, self.states, self.messages


@dataclass(frozen=True, eq=False)
class LoopState:
    """Everything the stage loop needs to continue exactly where it was (immutable).

    Attributes
    ----------
    stage : int
        Stages completed.
    states, previous : ndarray
        The states now and one stage before (``previous`` is None before the first stage).
    snapshot : TopologySnapshot
        The routing tables at the next stage's time.
    network : NetworkState
        The provider's :meth:`state`.
    comms : Any
        The communication model's ``state()``.
    rng, comms_rng : dict
        Bit-generator states of the game's and the communication model's draws.
    metric_names : tuple of str
        The mission's swarm metrics (NaN rows once no robot is left).
    """

    stage: int
    states: np.ndarray
    previous: np.ndarray | None
    snapshot: TopologySnapshot
    network: Any
    comms: Any
    rng: dict
    comms_rng: dict | None
    metric_names: tuple[str, ...]


class StageLoop:
    """The stage loop as an object that can be stepped, snapshotted and restored.

    Parameters
    ----------
    provider : NeighbourhoodProvider
        Network; reset at time 0 and advanced to ``warmup_s`` by :meth:`start`.
    controller : Controller
        The game controller, a mission's baseline or the MPC controller
        (:class:`~swarmgames.sim.controllers.Controller`).
    mission : Mission
        Its ``swarm_metrics`` (and ``robot_metrics``, if any) are recorded every stage.
    period_s, warmup_s : float
        Control period and the network's warm-up before the first stage, s.
    rng : numpy.random.Generator
        The game's draws.
    comms : IdealComms or RoutedComms, optional
        The communication model (:mod:`swarmgames.comms`); default: ideal delivery.
    comms_rng : numpy.random.Generator, optional
        The communication model's draws (losses, fading).
    faults : Faults, optional
        Crashes, radio failures and jamming (:mod:`swarmgames.sim.faults`); default: none.
        A crashed robot holds its state (velocities zeroed) and its decision columns are
        NaN; robots without a radio are out of everyone's range for the network and the
        communication layer; the mission's metrics count the robots alive, where they are.

    Notes
    -----
    :meth:`state` and :meth:`restore` make a run resumable (``swarmgames run --resume``):
    restoring a state and stepping gives bit for bit the records the loop gave after that
    state was taken. They need the provider's ``state``/``restore``; the controller and the
    mission hold no state between stages (their results are functions of their arguments).
    """

    def __init__(
        self,
        *,
        provider: Any,
        controller: Any,
        mission: Any,
        period_s: float,
        warmup_s: float,
        rng: np.random.Generator,
        comms: Any = None,
        comms_rng: np.random.Generator | None = None,
        faults: Any = None,
    ) -> None:
        self.provider, self.controller, self.mission = provider, controller, mission
        self.period_s, self.warmup_s = float(period_s), float(warmup_s)
        self.rng, self.comms_rng = rng, comms_rng
        if comms is None:
            from swarmgames.comms import IdealComms

            comms = IdealComms(controller.hops)
        self.comms = comms
        self.faults = faults
        self._robot_metrics = MissionHooks.of(mission).robot_metrics
        self._control = getattr(provider, "control_traffic", None)  # OLSR's own messages
        self.stage = 0
        self.states: np.ndarray | None = None
        self._prev: np.ndarray | None = None
        self._snap: TopologySnapshot | None = None
        self._metric_names: tuple[str, ...] = ()
        self._view: StageView | None = None
        self._overloaded = False

    def start(self, states: np.ndarray) -> None:
        """Place the robots at ``states`` at time 0, run the network through the warm-up
        and forget every message."""
        pos = np.array(states, dtype=float)
        n = pos.shape[0]
        if self.faults is None:
            from swarmgames.sim.faults import Faults

            self.faults = Faults.none(n)
        f = self.faults
        self.comms.reset()
        self.provider.reset(f.network_positions(pos, f.radio(0.0, pos)), 0.0)
        self._snap = self.provider.advance(
            self.warmup_s, f.network_positions(pos, f.radio(0.0, pos))
        )
        if self._control is not None:
            self._control()  # the warm-up's traffic is not part of any stage
        self.stage, self.states, self._prev, self._metric_names = 0, pos, None, ()
        self._view = None

    def step(self) -> StageRecord:
        """Run the next stage with the controller's decision and return its record.

        The controller's ``plan(loop)`` is called first, before the stage's messages are
        exchanged (the MPC controller predicts on this loop there and restores it); then the
        stage's problem (``controller.problem``) is decided.
        """
        started = time.perf_counter()
        if self._view is None:
            self.controller.plan(self)
        view = self.observe(started)
        try:
            dec = self.controller.decide(self.controller.problem(*view.problem_fields), self.rng)
        except PayoffError as exc:
            raise PayoffError(
                f"mission {self.mission.name!r}, stage {self.stage + 1} (t = {view.t:g} s): {exc}"
            ) from None
        return self.act(dec)

    @property
    def previous(self) -> np.ndarray | None:
        """The states one stage before (None before the first stage)."""
        return self._prev

    def observe(self, started: float | None = None) -> StageView:
        """The next stage up to the decision: the messages of the stage exchanged, what every
        robot holds (its messages) returned. Idempotent until :meth:`act` (the messages are
        exchanged once). ``started``: when the stage's work began (``time.perf_counter()``;
        default: now), for its wall time."""
        if self.states is None:
            raise RuntimeError("call start(states) before observe()")
        if self._view is None:
            pos, f = self.states, self.faults
            t = self.warmup_s + self.stage * self.period_s
            alive, radio = f.alive(t), f.radio(t, pos)
            t0 = time.perf_counter() if started is None else started
            messages, heard = self.comms.exchange(t, self._snap, pos, self.comms_rng, active=radio)
            self._view = StageView(t, pos, self._snap, messages, heard, alive, radio, t0)
        return self._view

    def act(self, dec) -> StageRecord:
        """Finish the observed stage with the decision ``dec`` (a ``StageSolution``: actions,
        next states and their measures), measure it, advance the network and return its
        record."""
        view = self.observe()
        t_stage, t, pos, snap = view.started, view.t, view.states, view.snapshot
        alive, radio, heard = view.alive, view.radio, view.heard
        prev = self._prev
        n = pos.shape[0]
        mean_h, max_h, n_comp, edges = swarm_graph_stats(snap)
        if alive.any():
            before = None if prev is None else prev[alive]
            measured = self.mission.swarm_metrics(pos[alive], before, t)
        else:  # nothing left to measure
            measured = dict.fromkeys(self._metric_names, float("nan"))
        extra = self._robot_metrics(pos, t) if self._robot_metrics is not None else {}
        new_pos = np.array(dec.next_states, dtype=float)
        new_pos[~alive] = pos[~alive]
        new_pos[~alive, 3:] = 0.0  # a crashed robot stops
        if (~alive).any() and np.isfinite(dec.expost_regret).any():
            # The ex-post regret is against the states reached: a crashed robot's own.
            problem = self.controller.problem(*view.problem_fields)
            regret = self.controller.expost_regret(problem, dec.actions, new_pos)
            dec = replace(dec, expost_regret=regret)
        snap_next, olsr = self._advance(t, new_pos)
        columns_olsr = {}
        if olsr is not None:  # sent during this period; a silenced robot sends none
            columns_olsr = {
                "olsr_messages": np.where(radio, olsr.messages, 0),
                "olsr_bytes": np.where(radio, olsr.bytes, 0),
            }
        columns = {**_robot_columns(dec, n), **heard.columns()}
        for name in DECISION_COLUMNS:  # a crashed robot decides nothing
            columns[name] = np.where(alive, columns[name], np.nan)
        columns.update(alive=alive, radio=radio, **columns_olsr, **extra)
        row = {"mean_payoff": _nanmean(np.where(alive, dec.payoff, np.nan))}
        row.update((name, float(v)) for name, v in measured.items())
        row.update(
            mean_hops=mean_h,
            max_hops=max_h,
            components=n_comp,
            oscillation=oscillation(prev, pos, new_pos),
            mean_info_age_s=_nanmean(heard.info_age_s),
            bytes_per_robot=float(np.mean(heard.bytes_sent + heard.bytes_forwarded) if n else 0.0),
            alive_robots=int(alive.sum()),
        )
        if columns_olsr:
            row["olsr_bytes_per_robot"] = float(np.mean(columns_olsr["olsr_bytes"]))
        row["channel_load"] = _nanmax(heard.channel_load)
        self._warn_overload(t, heard.channel_load)
        record = StageRecord(
            t=t,
            actions=np.asarray(dec.actions, dtype=np.int64),
            robot={name: np.array(val) for name, val in columns.items()},
            swarm=row,
            links=edges,
            after=new_pos,
            wall_s=time.perf_counter() - t_stage,
        )
        # The loop moves on only once the stage is complete (Ctrl-C keeps whole stages).
        self._metric_names = tuple(measured)
        self.stage, self._prev, self.states, self._snap = self.stage + 1, pos, new_pos, snap_next
        self._view = None
        return record

    def move(self, next_states: np.ndarray) -> np.ndarray:
        """Finish the observed stage without measuring it: every robot alive goes to its row
        of ``next_states`` (N, D) (a crashed robot holds its state, stopped), the network
        advances one control period and its OLSR traffic of the period is dropped; returns
        the states reached. What a learner's environment steps with (:meth:`act` records the
        stage's measures too)."""
        view = self.observe()
        pos, alive = view.states, view.alive
        new_pos = np.array(next_states, dtype=float)
        new_pos[~alive] = pos[~alive]
        new_pos[~alive, 3:] = 0.0
        snap_next = self._advance(view.t, new_pos)[0]
        self.stage, self._prev, self.states, self._snap = self.stage + 1, pos, new_pos, snap_next
        self._view = None
        return new_pos

    def _advance(self, t: float, new_pos: np.ndarray):
        """The network one control period on from ``t`` with the robots at ``new_pos``: its
        routing tables then, and OLSR's traffic of the period (None without a model of it)."""
        f = self.faults
        t_next = t + self.period_s
        snap_next = self.provider.advance(
            t_next, f.network_positions(new_pos, f.radio(t_next, new_pos))
        )
        return snap_next, (self._control() if self._control is not None else None)

    def _warn_overload(self, t: float, load: np.ndarray) -> None:
        """Say once per run when a stage's traffic cannot fit the decision window."""
        worst = _nanmax(load)
        if self._overloaded or not worst > 1.0:
            return
        self._overloaded = True
        window = getattr(self.comms, "decide_after_s", float("nan"))
        warnings.warn(
            ChannelOverloadWarning(
                f"at t = {t:g} s the busiest neighbourhood offers {worst * window:.3g} s of "
                f"airtime for a decision window of {window:g} s (channel load {worst:.2f}): "
                "messages cannot all arrive by the decision; lower comms.jitter_s or "
                "network.hops, send smaller messages, or raise comms.decide_after_s"
            ),
            stacklevel=2,
        )

    def state(self) -> LoopState:
        """Everything needed to continue from here (see the class notes).

        Raises
        ------
        SnapshotUnsupported
            The provider cannot snapshot its state (ns-3), or has no ``state`` method.
        """
        from swarmgames.network.provider import SnapshotUnsupported

        if self.states is None:
            raise RuntimeError("call start(states) before state()")
        if self._view is not None:
            raise RuntimeError("state() is taken between stages, not after observe()")
        take = getattr(self.provider, "state", None)
        if take is None:
            raise SnapshotUnsupported(
                f"the network provider {getattr(self.provider, 'name', '?')!r} has no "
                "state()/restore(), so the run cannot be checkpointed"
            )
        return LoopState(
            stage=self.stage,
            states=self.states.copy(),
            previous=None if self._prev is None else self._prev.copy(),
            snapshot=self._snap,
            network=take(),
            comms=self.comms.state(),
            rng=copy.deepcopy(self.rng.bit_generator.state),
            comms_rng=(
                None
                if self.comms_rng is None
                else copy.deepcopy(self.comms_rng.bit_generator.state)
            ),
            metric_names=self._metric_names,
        )

    def restore(self, state: LoopState) -> None:
        """Continue from ``state`` (taken by :meth:`state` of a loop built the same way)."""
        if self.faults is None:
            from swarmgames.sim.faults import Faults

            self.faults = Faults.none(state.states.shape[0])
        self.provider.restore(state.network)
        self.comms.restore(state.comms)
        self.rng.bit_generator.state = copy.deepcopy(state.rng)
        if self.comms_rng is not None and state.comms_rng is not None:
            self.comms_rng.bit_generator.state = copy.deepcopy(state.comms_rng)
        self.stage = int(state.stage)
        self.states = np.array(state.states, dtype=float)
        self._prev = None if state.previous is None else np.array(state.previous, dtype=float)
        self._snap = state.snapshot
        self._metric_names = tuple(state.metric_names)
        self._view = None


def run_stages(
    *,
    provider: Any,
    controller: Any,
    mission: Any,
    states: np.ndarray,
    n_stages: int,
    period_s: float,
    warmup_s: float,
    rng: np.random.Generator,
    progress: Any = None,
    comms: Any = None,
    comms_rng: np.random.Generator | None = None,
    faults: Any = None,
) -> StageLog:
    """Run ``n_stages`` stages of a :class:`StageLoop` from ``states`` and return the
    :class:`StageLog` (the parameters are those of :class:`StageLoop`).

    Parameters
    ----------
    states : ndarray, shape (N, D)
        Start states; the first three columns are positions (x, y, z) in metres (the network
        sees only those).
    progress : callable ``(done: int) -> None``, optional
        Called after every stage.
    """
    loop = StageLoop(
        provider=provider,
        controller=controller,
        mission=mission,
        period_s=period_s,
        warmup_s=warmup_s,
        rng=rng,
        comms=comms,
        comms_rng=comms_rng,
        faults=faults,
    )
    return drive(loop, states, n_stages, progress=progress)


def drive(
    loop: StageLoop,
    start: np.ndarray,
    n_stages: int,
    *,
    records: list[StageRecord] | None = None,
    progress: Any = None,
    on_stage: Any = None,
    wall_s: float = 0.0,
) -> StageLog:
    """Step ``loop`` until ``n_stages`` stages are complete or Ctrl-C stops it.

    Parameters
    ----------
    loop : StageLoop
        Started (:meth:`StageLoop.start` from ``start``) or restored after
        ``len(records)`` stages.
    start : ndarray, shape (N, D)
        The states before the first stage.
    records : list of StageRecord, optional
        The stages completed before (a resumed run); extended in place.
    progress : callable ``(done: int) -> None``, optional
    on_stage : callable ``(record, loop) -> None``, optional
        Called after every stage (the run folder's journal appends it).
    wall_s : float
        Wall time already spent on the run (a resumed run), s.
    """
    records = [] if records is None else records
    if loop.states is None:
        loop.start(start)
    interrupted = False
    t0 = time.perf_counter()
    try:
        while loop.stage < n_stages:
            record = loop.step()
            with deferred_interrupts():  # a stage is kept everywhere or nowhere
                records.append(record)
                if on_stage is not None:
                    on_stage(record, loop)
            if progress is not None:
                progress(loop.stage)
            raise_if_signalled()  # a signal whose exception C code swallowed
    except KeyboardInterrupt:
        interrupted = True
    return StageLog.from_records(
        start,
        records,
        interrupted=interrupted,
        wall_s=wall_s + time.perf_counter() - t0,
        period_s=loop.period_s,
        warmup_s=loop.warmup_s,
    )
