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
from swarmgames.errors import ConfigError, RunFolderError, SwarmgamesError
from swarmgames.missions import Mission, get_mission
from swarmgames.sim.controllers import make_controller
from swarmgames.sim.faults import Faults
from swarmgames.sim.loop import StageLog, StageLoop, drive
from swarmgames.sim.memory import check_memory
from swarmgames.sim.progress import ProgressBar
from swarmgames.sim.result import RunResult
from swarmgames.sim.signals import signals_interrupt

__all__ = ["NotResumableError", "build_mission", "resume", "run"]


class NotResumableError(SwarmgamesError):
    """A run folder cannot be continued (no checkpoint: ns-3, ``sim.checkpoint_every = 0``,
    a provider without ``state()``); its summary and figures were rebuilt from the completed
    stages instead."""


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


def _check_mission(config: ScenarioConfig, mission: Mission | None) -> Mission:
    if mission is None:
        return build_mission(config)
    if not isinstance(mission, Mission):
        raise TypeError(
            f"mission must follow the swarmgames.missions.Mission protocol (got "
            f"{type(mission).__name__}); swarmgames.missions.check_mission(mission) says what "
            "is missing"
        )
    return mission


def build_loop(config: ScenarioConfig, mission: Mission, provider: Any):
    """The start states, the stage loop and the number of stages of a run of ``config``:
    every random draw from the children of ``SeedSequence(config.seed)``, so that a resumed
    run builds the same objects as the run it continues."""
    # Children 0-2 are those of runs before the communication layer and faults (same draws).
    seeds = np.random.SeedSequence(config.seed).spawn(5)
    rng_start, rng_net, rng_game, rng_comms, rng_faults = (np.random.default_rng(s) for s in seeds)
    sw, sim = config.swarm, config.sim
    states = _initial_states(mission, sw.n_robots, rng_start)
    if provider is None:
        from swarmgames.sim.providers import provider_from_config

        provider = provider_from_config(config.network, sw.n_robots, rng_net)
    from swarmgames.sim.providers import comms_from_config

    loop = StageLoop(
        provider=provider,
        controller=make_controller(config, mission),
        mission=mission,
        period_s=sim.control_period_s,
        warmup_s=sim.warmup_s,
        rng=rng_game,
        comms=comms_from_config(config, states.shape[1], provider),
        comms_rng=rng_comms,
        faults=Faults.from_config(config.faults, sw.n_robots, rng_faults),
    )
    n_stages = max(1, int(np.floor(sim.duration_s / sim.control_period_s + 1e-9)))
    return states, loop, n_stages


def _label(config: ScenarioConfig) -> str:
    return f"{config.name}: {config.swarm.n_robots} robots, {config.network.backend}"


def run(
    config: ScenarioConfig | None = None,
    out: Any = None,
    progress: bool = True,
    *,
    force: bool = False,
    provider: Any = None,
    mission: Mission | None = None,
    figures: bool = True,
) -> RunResult:
    """Run a mission and write its run folder.

    Parameters
    ----------
    config : ScenarioConfig, optional
        The scenario (default: ``ScenarioConfig()``, the paper's experiment with 7 UAVs).
    out : RunFolder, str or Path, optional
        Where to write ``config.toml``, ``trajectory.csv``, ``metrics.csv``, ``swarm.csv``,
        ``manifest.json``, ``timeseries.png``, ``paths.png``, ``animation.gif`` and
        ``summary.json``. The tables grow stage by stage, so that whatever stops the run
        (Ctrl-C, SIGTERM, ``kill -9``, running out of memory) its completed stages are in
        them, and :func:`resume` can continue it (see :mod:`swarmgames.sim.journal`).
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
    figures : bool, default True
        Write ``timeseries.png``, ``paths.png`` and ``animation.gif`` (``sim.animation``);
        false: the tables and the summary alone (what a sweep's runs write by default).

    Returns
    -------
    RunResult
        Tables (``.to_frame()``), plots (``.plot()``), ``.summary``. If Ctrl-C, SIGTERM or
        SIGHUP stopped the run, ``.interrupted`` is true and the completed stages are kept (and
        written).

    Raises
    ------
    RunFolderError
        ``out`` cannot be used: not empty without ``force``, or being written by another
        process (:class:`~swarmgames.runfolder.RunFolder` holds its lock for the run).
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
    custom = {
        "custom_mission": mission is not None,
        "custom_provider": None if provider is None else getattr(provider, "name", "?"),
    }
    mission = _check_mission(config, mission)
    check_memory(config, mission)  # refuse a run that cannot fit, before it starts
    # SIGTERM and SIGHUP (kill, timeout, schedulers, a closed terminal) stop the run like
    # Ctrl-C: the completed stages are kept and written.
    with signals_interrupt():
        opened = out is not None and not isinstance(out, RunFolder)
        if opened:
            out = RunFolder(Path(out), force=force)
        try:
            t0 = time.perf_counter()
            states, loop, n_stages = build_loop(config, mission, provider)
            loop.start(states)
            journal = None
            if out is not None:
                from swarmgames.sim.journal import RunJournal

                journal = RunJournal.begin(
                    out, config, loop, states, n_stages, mission=mission.name, custom=custom
                )
            log = _drive(loop, states, n_stages, config, progress, journal, [], 0.0)
            wall_s = time.perf_counter() - t0
            return _finish(log, config, mission, wall_s, journal, progress, figures)
        finally:
            if out is not None:
                if opened:
                    out.discard_if_empty()  # a run that failed before its first stage
                out.close()  # the folder's lock: the run's writing is over


def _drive(loop, states, n_stages, config, progress, journal, records, wall_s) -> StageLog:
    """Run the remaining stages with a progress bar; a failure is marked in the manifest."""
    with ProgressBar(_label(config), progress, total=n_stages) as tick:
        if tick is not None and records:
            tick(len(records))
        try:
            return drive(
                loop,
                states,
                n_stages,
                records=records,
                progress=tick,
                on_stage=None if journal is None else journal.stage,
                wall_s=wall_s,
            )
        except BaseException as exc:
            if journal is not None:
                journal.fail(exc)
            raise


def _finish(
    log, config, mission, wall_s: float, journal, progress: bool, figures: bool
) -> RunResult:
    """The run's result; with a run folder, its figures, animation and summary written under
    a progress bar of their own. The manifest never says "running" once this stops."""
    try:
        result = RunResult.from_log(log, config, mission, wall_s)
        if journal is not None:
            with ProgressBar(f"{config.name}: figures and animation", progress and figures) as tick:
                journal.finish(
                    result,
                    animation=config.sim.animation,
                    frames=config.sim.animation_frames,
                    progress=tick,
                    figures=figures,
                )
    except BaseException as exc:
        if journal is not None:
            journal.fail(exc)
        raise
    return result


def resume(
    folder: Any,
    progress: bool = True,
    *,
    provider: Any = None,
    mission: Mission | None = None,
    figures: bool = True,
) -> RunResult:
    """Continue an interrupted run from the last checkpoint of its folder.

    The tables are cut back to the checkpoint (stages completed after it are run again), the
    stage loop is restored (states, random states, the network's and the communication
    model's state) and the run goes on to its end: its files are then those an
    uninterrupted run writes, bit for bit, wall times aside.

    Parameters
    ----------
    folder : RunFolder, str or Path
        A run folder written by :func:`run` (it has a ``manifest.json``).
    progress : bool
        Show a progress bar.
    provider, mission : optional
        The objects given to :func:`run`, if any (they cannot be rebuilt from the folder).
    figures : bool, default True
        Write the figures and the animation (as :func:`run`).

    Returns
    -------
    RunResult
        As :func:`run` returns it (``.interrupted`` if stopped again).

    Raises
    ------
    RunFolderError
        Not a run folder, a complete run, or files changed since the checkpoint.
    NotResumableError
        The run has no checkpoint (its network cannot snapshot its state, such as ns-3, or
        ``sim.checkpoint_every = 0``); ``summary.json`` and the figures are rebuilt from its
        completed stages before this is raised.
    """
    from swarmgames.config import load_config
    from swarmgames.runfolder import RunFolder
    from swarmgames.sim.journal import RunJournal, read_checkpoint, read_manifest, verify_run

    path = folder.path if isinstance(folder, RunFolder) else Path(folder)
    manifest = read_manifest(path)
    if manifest["status"] == "complete":
        raise RunFolderError(
            f"the run in {path} is complete ({manifest['stages_completed']} stages): nothing "
            "to resume"
        )
    if manifest.get("custom_mission") and mission is None:
        raise RunFolderError(
            f"the run in {path} used a mission object given to swarmgames.run(); resume it "
            "from Python with swarmgames.resume(folder, mission=...)"
        )
    if manifest.get("custom_provider") and provider is None:
        raise RunFolderError(
            f"the run in {path} used a network provider given to swarmgames.run() "
            f"({manifest['custom_provider']!r}); resume it from Python with "
            "swarmgames.resume(folder, provider=...)"
        )
    with signals_interrupt():
        out = RunFolder.of(folder, force=True)  # the folder's lock, before anything is read
        try:
            manifest = verify_run(path)
            config = load_config(path / "config.toml")
            mission = _check_mission(config, mission)
            checkpoint = read_checkpoint(out, manifest)
            if checkpoint is None:
                _rebuild(out, config, mission, manifest)
            _, loop, n_stages = build_loop(config, mission, provider)
            try:
                loop.restore(checkpoint.loop)
            except (ValueError, TypeError, KeyError, AttributeError) as exc:
                raise RunFolderError(
                    f"the checkpoint in {path} does not fit its run: {str(exc)[:200]}"
                ) from None
            journal, records = RunJournal.reopen(out, checkpoint, manifest)
            t0 = time.perf_counter()
            log = _drive(
                loop, journal.start, n_stages, config, progress, journal, records, checkpoint.wall_s
            )
            wall_s = checkpoint.wall_s + time.perf_counter() - t0
            return _finish(log, config, mission, wall_s, journal, progress, figures)
        finally:
            out.close()  # the folder's lock: the run's writing is over


def _rebuild(out, config, mission, manifest) -> None:
    """Write the summary and the figures of a run that cannot be continued from its stage
    records, then raise :class:`NotResumableError`."""
    from swarmgames.sim.journal import read_records

    start, records, period = read_records(out, manifest)
    log = StageLog.from_records(
        start,
        records,
        interrupted=True,
        wall_s=float(sum(r.wall_s for r in records)),
        period_s=period,
        warmup_s=config.sim.warmup_s,
    )
    result = RunResult.from_log(log, config, mission, log.wall_s)
    result.write_outputs(out, config.sim.animation, config.sim.animation_frames)
    raise NotResumableError(
        f"cannot continue the run in {out.path}: "
        f"{manifest.get('not_resumable_because') or 'it has no checkpoint'}; summary.json and "
        f"the figures were rebuilt from its {len(records)} completed stages"
    )
