"""The stage loop: network, local games, actions, repeated every control period.

One stage at time :math:`t_k = t_{warm} + k\\,\\Delta t`:

1. the network provider is advanced to :math:`t_k` with the robots held at the positions they
   reached (OLSR keeps running between stages, so its tables lag the geometry as in ns-3);
2. every robot reads its neighbourhood :math:`N_i(h)` from its own routing table;
3. the controller decides every robot's action (the stage pipeline of
   :mod:`swarmgames.game.stage`: all local games built, evaluated, solved and measured in
   batches; or the Lloyd baseline);
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

import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.sparse import csgraph, csr_array

from swarmgames.topology import TopologySnapshot

__all__ = ["StageLog", "oscillation", "run_stages", "swarm_graph_stats"]


#: Above this many robots the hop statistics come from the routing-table entries alone
#: (an all-pairs BFS would need N^2 memory).
HOP_STATS_MAX_NODES = 2000


def swarm_graph_stats(snapshot: TopologySnapshot) -> tuple[float, int, int, np.ndarray]:
    """Hop statistics and connectivity of the swarm as its routing tables see it.

    Returns the mean and max hop count over the ordered pairs that can reach each other, the
    number of connected components of the 1-hop links (symmetric neighbours in the tables),
    and those links as undirected edges ``(E, 2)`` with ``i < j``.

    Notes
    -----
    Up to :data:`HOP_STATS_MAX_NODES` robots the hops are breadth-first distances over the
    tables' 1-hop links (what settled OLSR routes, paper Fig. 1's "unreachable pairs left
    out"), so they do not depend on how far the tables themselves reach: OLSR in HELLO-only
    mode (h <= 2) holds no route longer than 2 hops, yet the swarm may be 6 hops across.
    Larger swarms use the table entries, which may stop at h hops.
    """
    n = snapshot.n_robots
    one = snapshot.hops == 1
    a, b = snapshot.owner[one], snapshot.dest[one]
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    edges = np.unique(np.column_stack([lo, hi]), axis=0) if lo.size else np.zeros((0, 2), int)
    graph = csr_array((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    n_comp = int(csgraph.connected_components(graph, directed=False)[0])
    if n <= HOP_STATS_MAX_NODES and len(edges):
        dist = csgraph.shortest_path(graph, directed=False, unweighted=True)
        hops = dist[np.isfinite(dist) & (dist > 0)]
    else:
        hops = snapshot.hops
    mean_h = float(hops.mean()) if hops.size else 0.0
    max_h = int(hops.max()) if hops.size else 0
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


@dataclass
class StageLog:
    """Everything recorded by the loop; arrays are stacked over the S completed stages.

    Attributes
    ----------
    times : (S,) stage times, s.  states : (S + 1, N, D) states at each stage and after the
    last one.  actions : (S, N).  per_robot : dict of (S, N) arrays (payoff, neighbours,
    local_regret, global_regret, iterations, converged, solve_ms, integrate_ms, then the
    mission's robot metrics).  swarm : dict of (S,) arrays (mean_payoff, the mission's
    metrics, mean_hops, max_hops, components, oscillation).  links : list of (E, 2) 1-hop
    edges per stage.  interrupted : whether Ctrl-C stopped the loop.  wall_s : loop time, s.
    stage_s : (S,) wall time of each stage, s.
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


#: Per-robot columns of a decision, NaN for a robot that has crashed.
DECISION_COLUMNS = ("payoff", "local_regret", "global_regret", "solve_ms", "integrate_ms")


def _robot_columns(stage, n: int) -> dict[str, np.ndarray]:
    """The per-robot columns of ``metrics.csv`` from a :class:`StageSolution`; times are
    amortised over the robots."""
    return {
        "payoff": stage.payoff,
        "neighbours": stage.neighbours,
        "local_regret": stage.local_regret,
        "global_regret": stage.global_regret,
        "iterations": stage.iterations,
        "converged": stage.converged,
        "solve_ms": np.full(n, 1e3 * stage.solve_s / max(1, n)),
        "integrate_ms": np.full(n, 1e3 * stage.integrate_s / max(1, n)),
    }


def _nanmean(values: np.ndarray) -> float:
    """Mean of the finite values (NaN when there are none)."""
    ok = np.isfinite(values)
    return float(values[ok].mean()) if ok.any() else float("nan")


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
    """Run ``n_stages`` stages and return the :class:`StageLog`.

    Parameters
    ----------
    provider : NeighbourhoodProvider
        Network; reset at time 0 and advanced to ``warmup_s`` before the first stage.
    controller : object with ``decide(snapshot, states, rng) -> StageSolution``
        The game controller or the Lloyd baseline (:mod:`swarmgames.sim.controllers`).
    mission : Mission
        Its ``swarm_metrics`` (and ``robot_metrics``, if any) are recorded every stage.
    states : ndarray, shape (N, D)
        Start states; the first three columns are positions (x, y, z) in metres (the network
        sees only those).
    progress : callable ``(done: int) -> None``, optional
        Called after every stage.
    comms : IdealComms or RoutedComms, optional
        The communication model (:mod:`swarmgames.comms`); default: ideal delivery. Its
        per-robot measurements join ``per_robot``.
    comms_rng : numpy.random.Generator, optional
        The communication model's draws (losses, fading).
    faults : Faults, optional
        Crashes, radio failures and jamming (:mod:`swarmgames.sim.faults`); default: none.
        A crashed robot holds its state (velocities zeroed) and its per-robot measures are
        NaN; robots without a radio are out of everyone's range for the network and the
        communication layer; the mission's metrics count the robots alive, where they are.
    """
    pos = np.array(states, dtype=float)
    n = pos.shape[0]
    times, traj, acts, stage_s, links = [], [pos.copy()], [], [], []
    per_robot: dict[str, list] = {}
    swarm: dict[str, list] = {}
    interrupted = False
    t_start = time.perf_counter()
    robot_metrics = getattr(mission, "robot_metrics", None)
    prev = None
    if comms is None:
        from swarmgames.comms import IdealComms

        comms = IdealComms(getattr(controller, "hops", 1))
    comms.reset()
    if faults is None:
        from swarmgames.sim.faults import Faults

        faults = Faults.none(n)
    measured: dict[str, float] = {}
    try:
        provider.reset(faults.network_positions(pos, faults.radio(0.0, pos)), 0.0)
        snap = provider.advance(warmup_s, faults.network_positions(pos, faults.radio(0.0, pos)))
        control = getattr(provider, "control_traffic", None)  # OLSR's own messages, if any
        if control is not None:
            control()  # the warm-up's traffic is not part of any stage
        for k in range(n_stages):
            t_stage = time.perf_counter()
            t = warmup_s + k * period_s
            alive, radio = faults.alive(t), faults.radio(t, pos)
            inbox, heard = comms.exchange(t, snap, pos, comms_rng, active=radio)
            dec = controller.decide(snap, pos, rng, inbox=inbox)
            mean_h, max_h, n_comp, edges = swarm_graph_stats(snap)
            if alive.any():
                measured = mission.swarm_metrics(pos[alive], None if prev is None else prev[alive])
            else:  # nothing left to measure
                measured = dict.fromkeys(measured, float("nan"))
            extra = robot_metrics(pos) if robot_metrics is not None else {}
            new_pos = np.array(dec.next_states, dtype=float)
            new_pos[~alive] = pos[~alive]
            new_pos[~alive, 3:] = 0.0  # a crashed robot stops
            t_next = t + period_s
            net_pos = faults.network_positions(new_pos, faults.radio(t_next, new_pos))
            snap_next = provider.advance(t_next, net_pos)
            if control is not None:  # sent during this period; a silenced robot sends none
                olsr = control()
                columns_olsr = {
                    "olsr_messages": np.where(radio, olsr.messages, 0),
                    "olsr_bytes": np.where(radio, olsr.bytes, 0),
                }
            else:
                columns_olsr = {}
            # A stage is recorded only once it is complete (Ctrl-C keeps whole stages).
            times.append(t)
            acts.append(np.asarray(dec.actions, dtype=np.int64))
            columns = {**_robot_columns(dec, n), **heard.columns()}
            for name in DECISION_COLUMNS:  # a crashed robot decides nothing
                columns[name] = np.where(alive, columns[name], np.nan)
            columns.update(alive=alive, radio=radio, **columns_olsr, **extra)
            for name, val in columns.items():
                per_robot.setdefault(name, []).append(np.asarray(val))
            row = {"mean_payoff": _nanmean(np.where(alive, dec.payoff, np.nan))}
            row.update((name, float(v)) for name, v in measured.items())
            row.update(
                mean_hops=mean_h,
                max_hops=max_h,
                components=n_comp,
                oscillation=oscillation(prev, pos, new_pos),
                mean_info_age_s=_nanmean(heard.info_age_s),
                bytes_per_robot=float(
                    np.mean(heard.bytes_sent + heard.bytes_forwarded) if n else 0.0
                ),
                alive_robots=int(alive.sum()),
            )
            if columns_olsr:
                row["olsr_bytes_per_robot"] = float(np.mean(columns_olsr["olsr_bytes"]))
            for name, val in row.items():
                swarm.setdefault(name, []).append(val)
            links.append(edges)
            prev, pos, snap = pos, new_pos, snap_next
            traj.append(pos.copy())
            stage_s.append(time.perf_counter() - t_stage)
            if progress is not None:
                progress(k + 1)
    except KeyboardInterrupt:
        interrupted = True
    s = len(times)
    return StageLog(
        times=np.asarray(times, dtype=float),
        states=np.stack(traj[: s + 1]),
        actions=np.stack(acts) if acts else np.zeros((0, n), dtype=np.int64),
        per_robot={k: np.stack(v) for k, v in per_robot.items()},
        swarm={k: np.asarray(v) for k, v in swarm.items()},
        links=links,
        interrupted=interrupted,
        wall_s=time.perf_counter() - t_start,
        stage_s=np.asarray(stage_s),
        period_s=float(period_s),
        warmup_s=float(warmup_s),
    )
