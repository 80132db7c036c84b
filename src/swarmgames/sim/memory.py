"""The memory a run will need, estimated from its configuration before it starts.

:func:`estimate_memory` turns a configuration (and its built mission) into the sizes of a
stage — N, the neighbourhood size K, the actions A, the solver's dtype, the controller — and
adds what the run keeps besides (its stages, the network's tables, the interpreter);
:func:`check_memory` refuses a run whose estimate exceeds ``sim.memory_limit_gib`` (default:
80 % of the memory available when the run starts) with a :class:`MemoryLimitError` naming
the knobs that change it. ``swarmgames run`` and ``swarmgames config check`` both check, so
a run that cannot fit stops before anything is simulated.

The neighbourhood size is that of a swarm spread uniformly over a disc of radius R: robot i's
N_i(h) reaches at most h radio ranges r, so

.. math:: K = \\begin{cases} N & R \\le h r / 2 \\\\
          1 + (N - 1) \\min\\bigl(1, (h r / R)^2\\bigr) & \\text{otherwise,} \\end{cases}

evaluated for the densest disc the swarm can reach: the take-off disc, or the region the
mission covers (its ``extent()``, as the disc of the same area) if that is smaller, but no
smaller than the take-off disc shrunk by the distance a robot flies in the mission
(``sim.duration_s`` at ``swarm.step_m / sim.control_period_s``). A coverage swarm of 300
UAVs takes off from a 1.4 km disc (K ≈ 81) and can reach the 612 m ROI in 90 s, where every
UAV is within two hops of every other (K = 300); 1 000 UAVs take off from a 2.6 km disc that
90 s shrink to 1.7 km at most (K ≈ 188). It is the size of the largest games (those near
the centre), which is what the padded batches hold. With ``game.virtual_mean = "exact"`` a
game also holds its context, the robots of its members' neighbourhoods: K is then that of
2h hops (the formula with 2h r).

With the built-in OLSR model the network's own state is added: every robot's 2-hop set holds
K1² entries (K1 the same formula for one hop), 16 bytes each between HELLO rounds and about
80 at the peak of a round (measured at 150 and 300 robots within range: 0.25 and 1.85 GiB). A
round happens before the stage's games are built, so only the part above the stage's own peak
is added.
"""

from __future__ import annotations

import math
import os

from swarmgames.errors import ConfigError
from swarmgames.game.capabilities import capabilities_of
from swarmgames.game.memory import GIB, MemoryEstimate, stage_memory
from swarmgames.missions.protocol import MissionHooks
from swarmgames.names import CONTROLLERS

__all__ = [
    "INTERPRETER_BYTES",
    "MemoryLimitError",
    "available_memory_bytes",
    "check_memory",
    "estimate_memory",
    "memory_limit_bytes",
    "neighbourhood_size",
]

#: Python, numpy, scipy, Numba, pandas and matplotlib once imported (resident, untraced).
INTERPRETER_BYTES = 0.35 * GIB

#: Bytes per entry of the OLSR model's 2-hop sets (N K1² entries): kept between HELLO rounds,
#: and at the peak of a HELLO round (measured: 93-94 at 150 and 300 robots within range).
_OLSR_KEPT, _OLSR_PEAK = 16.0, 80.0

#: Share of the available memory a run may plan to use when ``sim.memory_limit_gib`` is unset.
AVAILABLE_SHARE = 0.8


class MemoryLimitError(ConfigError):
    """A run's estimated peak memory exceeds its limit; ``estimate`` and ``limit_bytes``
    carry the numbers."""

    def __init__(self, message: str, estimate: MemoryEstimate, limit_bytes: float) -> None:
        super().__init__(message)
        self.estimate = estimate
        self.limit_bytes = limit_bytes


def available_memory_bytes() -> float | None:
    """Memory available to a new process now (Linux ``MemAvailable``; else free physical
    pages), bytes; None when the system does not say."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0
    except OSError:
        pass
    try:
        return float(os.sysconf("SC_AVPHYS_PAGES")) * float(os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):
        return None


def memory_limit_bytes(config) -> tuple[float, str]:
    """The limit a run is held to, bytes, and how it was set (for the message)."""
    limit = config.sim.memory_limit_gib
    if limit is not None:
        return float(limit) * GIB, f"sim.memory_limit_gib = {limit:g}"
    avail = available_memory_bytes()
    if avail is None:
        return math.inf, "no limit (the system does not report its available memory)"
    return (
        AVAILABLE_SHARE * avail,
        f"{AVAILABLE_SHARE:.0%} of the {avail / GIB:.1f} GiB available (sim.memory_limit_gib "
        "unset)",
    )


def _disc_neighbours(n: int, radius_m: float, reach_m: float) -> int:
    if radius_m <= reach_m / 2.0:
        return n
    return math.ceil(1 + (n - 1) * min(1.0, (reach_m / radius_m) ** 2))


def _radio_range(network) -> float:
    from swarmgames.network.parameters import RadioParameters
    from swarmgames.network.propagation import max_range

    if network.backend == "disk":
        return float(network.disk_radius_m)
    return float(max_range(RadioParameters(**network.radio.model_dump())))


def neighbourhood_size(config, mission=None) -> int:
    """K, the neighbourhood size (owner included) of the largest local games of the run:
    the module's formula for the take-off disc and for the mission's region, over h hops
    (2h with ``game.virtual_mean = "exact"``, whose games hold the members' neighbours).

    Examples
    --------
    >>> from swarmgames.config import ScenarioConfig
    >>> neighbourhood_size(ScenarioConfig())   # the default 7 UAVs: one clique
    7
    """
    if mission is None:
        from swarmgames.sim.runner import build_mission

        mission = build_mission(config)
    n, h, net = config.swarm.n_robots, int(config.network.hops), config.network
    if config.game.virtual_mean == "exact":
        h *= 2
    if net.backend == "knn":
        return int(min(n, sum(net.knn_k**i for i in range(h + 1))))
    reach = h * _radio_range(net)
    takeoff = getattr(mission, "takeoff", None)
    if takeoff is None:
        from swarmgames.missions.motion import TakeOff

        takeoff = TakeOff.of(config.swarm)
    densest = float(takeoff.radius_m)
    extent = MissionHooks.of(mission).extent
    if extent is not None:
        x0, x1, y0, y1 = (float(v) for v in extent())
        region = 0.5 * math.sqrt(max(x1 - x0, 0.0) * max(y1 - y0, 0.0))
        # The swarm can close in on the region by at most its speed times the mission.
        sw, sim = config.swarm, config.sim
        speed = sw.step_m / sim.control_period_s if sw.action_set == "headings" else None
        travel = (speed or sw.max_speed_m_s) * sim.duration_s
        densest = min(densest, max(region, densest - travel))
    return int(_disc_neighbours(n, densest, reach))


def _one_hop_size(config, mission) -> int:
    """K1, robots within one radio range of the densest robots (owner included)."""
    update = {
        "network": config.network.model_copy(update={"hops": 1}),
        "game": config.game.model_copy(update={"virtual_mean": "off"}),
    }
    return neighbourhood_size(config.model_copy(update=update), mission)


def _potentials_bytes(mission, k: int, a: int, games: int, n: int) -> tuple[float, float, float]:
    """Working memory of the mission's potentials for one batch, ``(unary, owner_unary,
    pairwise)`` bytes: what the potentials declare (``capabilities.memory``:
    ``stage_bytes(k, a, games, n)``); for others one more pairwise table beside the table
    and a crowding block."""
    from swarmgames.missions.geometry import crowding_bytes

    pot = mission.potentials
    if capabilities_of(pot).memory:
        return pot.stage_bytes(k, a, games, n)
    entries = float(games) * k * k * a * a
    return 0.0, 0.0, entries * 8.0 + crowding_bytes(entries)


def _solver_capabilities(config, mission):
    """What the run's solver does with its mission's potentials: whether it computes the
    pairwise tables on demand, and from which game size it shares one held table among equal
    games (:class:`~swarmgames.game.capabilities.SolverCapabilities`)."""
    from swarmgames.sim.controllers import solver_from_config

    return solver_from_config(config.game).capabilities(mission.potentials)


def estimate_memory(config, mission=None, *, whole_run: bool = True) -> MemoryEstimate:
    """Predicted peak memory of a run of ``config``.

    Parameters
    ----------
    config : ScenarioConfig
    mission : Mission, optional
        Its built mission (built here when None).
    whole_run : bool, default True
        Add what the run holds besides a stage: the stages kept, the network's tables and
        the interpreter; False: one stage only (what ``tests/sim/test_memory.py`` measures).

    Returns
    -------
    MemoryEstimate
    """
    if mission is None:
        from swarmgames.sim.runner import build_mission

        mission = build_mission(config)
    n = config.swarm.n_robots
    a = int(mission.action_model.n_actions)
    d = int(mission.state_dim)
    k = neighbourhood_size(config, mission)
    itemsize = 4 if config.game.dtype == "float32" else 8
    baseline = config.sim.controller not in CONTROLLERS  # a mission's: no game is solved
    centralised = config.game.solver == "centralised" and not baseline
    caps = _solver_capabilities(config, mission)
    kwargs = {
        "state_dim": d,
        "itemsize": itemsize,
        "pair_on_demand": not centralised and caps.pairs_on_demand,
        "held_sharing": None if centralised else caps.held_sharing_min,
    }
    first = stage_memory(n, k, a, **kwargs)
    unary, owner, pair_work = _potentials_bytes(mission, first.n_vars, a, first.batch_games, n)
    est = stage_memory(
        n,
        k,
        a,
        **kwargs,
        global_regret=config.sim.global_regret and not baseline,
        centralised=centralised,
        unary_bytes=unary,
        owner_unary_bytes=owner if config.sim.global_regret else 0.0,  # the ex-post's too
        pair_work_bytes=pair_work,
    )
    if not whole_run:
        return est
    stage = est.total_bytes
    stages = max(1, int(config.sim.duration_s / config.sim.control_period_s))
    est = est.with_part("stages kept and written", 8.0 * stages * n * (2 * d + 30))
    if config.network.backend == "olsr":
        # Every robot's 2-hop set holds K1² entries; a HELLO round builds them all at once.
        k1 = _one_hop_size(config, mission)
        two_hop = float(n) * k1 * k1
        kept, peak = _OLSR_KEPT * two_hop, _OLSR_PEAK * two_hop
        est = est.with_part("network: OLSR tables", kept)
        if peak > kept + stage:
            est = est.with_part(
                "network: OLSR HELLO processing beyond the stage", peak - kept - stage
            )
    else:
        est = est.with_part("network tables", 64.0 * n * k)
    return est.with_part("interpreter and libraries", INTERPRETER_BYTES)


def check_memory(config, mission=None) -> MemoryEstimate:
    """The run's estimate (:func:`estimate_memory`), or an error before it starts.

    Raises
    ------
    MemoryLimitError
        The estimate exceeds :func:`memory_limit_bytes`; the message gives both, the largest
        parts and the fields that change them.
    """
    if mission is None:
        from swarmgames.sim.runner import build_mission

        mission = build_mission(config)
    est = estimate_memory(config, mission)
    limit, how = memory_limit_bytes(config)
    if est.total_bytes <= limit:
        return est
    sw, game = config.swarm, config.game
    knobs = [
        f"swarm.n_robots ({sw.n_robots})",
        f"network.hops ({config.network.hops})",
        f"the take-off spread (swarm.start_max_neighbours = {sw.start_max_neighbours}, "
        f"swarm.start_radius_m = {sw.start_radius_m:g})",
    ]
    if config.network.backend == "olsr":
        knobs.append("network.backend = 'oracle' or 'disk' (no OLSR 2-hop sets)")
    if game.dtype == "float64":
        knobs.append("game.dtype = 'float32' (halves the pairwise tables)")
    if config.game.solver == "centralised":
        knobs.append("game.solver = 'mean_field' (local games instead of one swarm-wide game)")
    if config.sim.global_regret:
        knobs.append("sim.global_regret = false")
    if game.virtual_mean == "exact":
        knobs.append("game.virtual_mean = 'eq3' or 'outside' (games of h hops, not 2h)")
    knobs.append("sim.memory_limit_gib")
    raise MemoryLimitError(
        f"estimated peak memory must be <= {how} = {limit / GIB:.3g} GiB (got "
        f"{est.describe()}; N = {sw.n_robots} robots, K = {est.n_vars} per local game, "
        f"A = {int(mission.action_model.n_actions)} actions); change: " + ", ".join(knobs),
        est,
        limit,
    )
