"""``swarmgames.run``: one mission from a configuration to a run folder.

Examples
--------
>>> from swarmgames import ScenarioConfig, run            # doctest: +SKIP
>>> result = run(ScenarioConfig(seed=1), out=None)        # doctest: +SKIP
>>> result.to_frame().tail(1)                             # doctest: +SKIP
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

from swarmgames.config import ScenarioConfig
from swarmgames.errors import ConfigError
from swarmgames.missions import Mission, get_mission
from swarmgames.sim.controllers import make_controller
from swarmgames.sim.faults import Faults
from swarmgames.sim.loop import run_stages
from swarmgames.sim.memory import check_memory
from swarmgames.sim.progress import ProgressBar
from swarmgames.sim.result import RunResult
from swarmgames.sim.signals import signals_interrupt

__all__ = ["build_mission", "run"]


def build_mission(config: ScenarioConfig) -> Mission:
    """The mission ``config.scenario`` names, built from ``config`` (its registry entry's
    ``build``)."""
    return get_mission(config.scenario).build(config)


def _initial_states(mission: Mission, n: int, rng: np.random.Generator) -> np.ndarray:
    states = np.asarray(mission.initial_states(n, rng), dtype=float)
    want = (n, int(mission.state_dim))
    if states.shape != want:
        raise ConfigError(
            f"mission {mission.name!r}: initial_states returned shape {states.shape}, expected "
            f"{want} (swarm.n_robots x state_dim); swarmgames.missions.check_mission says more"
        )
    return states


def run(
    config: ScenarioConfig | None = None,
    out: Any = None,
    progress: bool = True,
    *,
    force: bool = False,
    provider: Any = None,
    mission: Mission | None = None,
) -> RunResult:
    """Run a mission and write its run folder.

    Parameters
    ----------
    config : ScenarioConfig, optional
        The scenario (default: ``ScenarioConfig()``, the paper's experiment with 7 UAVs).
    out : RunFolder, str or Path, optional
        Where to write ``config.toml``, ``trajectory.csv``, ``metrics.csv``, ``swarm.csv``,
        ``timeseries.png``, ``paths.png``, ``animation.gif`` and ``summary.json``.
        ``None``: nothing is written.
    progress : bool
        Show a progress bar (rich) on the terminal.
    force : bool
        When ``out`` is a path: allow writing into a non-empty folder.
    provider : NeighbourhoodProvider, optional
        A network to use instead of the one ``config.network`` names (for user-written
        providers); it is reset at the start of the run.
    mission : Mission, optional
        A mission object to run (for example one written in a notebook; see
        ``docs/missions.md``) instead of the registered mission ``config.scenario`` names.

    Returns
    -------
    RunResult
        Tables (``.to_frame()``), plots (``.plot()``), ``.summary``. If Ctrl-C, SIGTERM or
        SIGHUP stopped the run, ``.interrupted`` is true and the completed stages are kept (and
        written).

    Raises
    ------
    ConfigError
        An invalid configuration (the message names the field, the rule and the value); a
        :class:`~swarmgames.sim.memory.MemoryLimitError` when the run's estimated peak memory
        exceeds ``sim.memory_limit_gib``.
    TypeError
        ``mission`` does not have the attributes of :class:`~swarmgames.missions.Mission`.
    """
    from swarmgames.runfolder import RunFolder

    config = ScenarioConfig() if config is None else config
    if not isinstance(config, ScenarioConfig):
        raise TypeError(f"config must be a ScenarioConfig (got {type(config).__name__})")
    if mission is None:
        mission = build_mission(config)
    elif not isinstance(mission, Mission):
        raise TypeError(
            f"mission must follow the swarmgames.missions.Mission protocol (got "
            f"{type(mission).__name__}); swarmgames.missions.check_mission(mission) says what "
            "is missing"
        )
    check_memory(config, mission)  # refuse a run that cannot fit, before it starts
    # SIGTERM and SIGHUP (kill, timeout, schedulers, a closed terminal) stop the run like
    # Ctrl-C: the completed stages are kept and written.
    with signals_interrupt():
        if out is not None and not isinstance(out, RunFolder):
            out = RunFolder(Path(out), force=force)
        t0 = time.perf_counter()
        # Children 0-2 are those of runs before the communication layer and faults (same
        # draws).
        seeds = np.random.SeedSequence(config.seed).spawn(5)
        rng_start, rng_net, rng_game, rng_comms, rng_faults = (
            np.random.default_rng(s) for s in seeds
        )
        sw, sim = config.swarm, config.sim
        states = _initial_states(mission, sw.n_robots, rng_start)
        if provider is None:
            from swarmgames.sim.providers import provider_from_config

            provider = provider_from_config(config.network, sw.n_robots, rng_net)
        from swarmgames.sim.providers import comms_from_config

        comms = comms_from_config(config, states.shape[1], provider)
        controller = make_controller(config, mission)
        n_stages = max(1, int(np.floor(sim.duration_s / sim.control_period_s + 1e-9)))
        label = f"{config.name}: {sw.n_robots} robots, {config.network.backend}"
        with ProgressBar(label, progress, total=n_stages) as tick:
            log = run_stages(
                provider=provider,
                controller=controller,
                mission=mission,
                states=states,
                n_stages=n_stages,
                period_s=sim.control_period_s,
                warmup_s=sim.warmup_s,
                rng=rng_game,
                progress=tick,
                comms=comms,
                comms_rng=rng_comms,
                faults=Faults.from_config(config.faults, sw.n_robots, rng_faults),
            )
        result = RunResult.from_log(log, config, mission, time.perf_counter() - t0)
        if out is not None:
            result.write(out, animation=sim.animation, frames=sim.animation_frames)
        return result
