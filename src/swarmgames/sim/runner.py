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
from swarmgames.scenarios import (
    AccelerationActions,
    CoveragePotentials,
    HeadingActions,
    arena_for,
)
from swarmgames.sim.controllers import GameController, LloydController
from swarmgames.sim.loop import run_stages, start_positions
from swarmgames.sim.result import RunResult

__all__ = ["build_mission", "check_config", "run"]


def check_config(config: ScenarioConfig) -> None:
    """Checks that span several sections (each section validates itself on construction).

    Raises
    ------
    ConfigError
        A move faster than the speed limit, a mission shorter than one control period, or an
        ROI grid too fine or too coarse; the message names the fields and values.
    """
    sw, sim = config.swarm, config.sim
    speed = sw.step_m / sim.control_period_s
    if sw.action_set == "headings" and speed > sw.max_speed_m_s * (1 + 1e-12):
        raise ConfigError(
            "swarm.step_m / sim.control_period_s must be <= swarm.max_speed_m_s "
            f"(got {sw.step_m} m / {sim.control_period_s} s = {speed:g} m/s > "
            f"{sw.max_speed_m_s} m/s)"
        )
    if sim.duration_s < sim.control_period_s:
        raise ConfigError(
            "sim.duration_s must be >= sim.control_period_s "
            f"(got {sim.duration_s} < {sim.control_period_s})"
        )
    if config.game.solver == "centralised" and sim.controller == "game" and sw.n_robots > 300:
        raise ConfigError(
            "game.solver = 'centralised' holds an N^2 A^2 table: swarm.n_robots must be <= 300 "
            f"(got {sw.n_robots})"
        )


def build_mission(config: ScenarioConfig) -> tuple[Any, Any]:
    """The coverage potentials and the UAV action model of ``config``."""
    try:
        potentials = CoveragePotentials.from_config(config.coverage, config.game.alpha_b)
    except ValueError as exc:
        raise ConfigError(f"coverage: {exc}") from None
    sw = config.swarm
    bounds = arena_for(potentials.roi, sw.start_center_m, sw.start_radius_m, sw.arena_margin_m)
    if sw.action_set == "acceleration":
        model = AccelerationActions(
            sw.accel_step_m_s2,
            sw.accel_levels,
            sw.max_speed_m_s,
            config.sim.control_period_s,
            bounds,
        )
    else:
        model = HeadingActions.from_config(sw, bounds)
    return potentials, model


def run(
    config: ScenarioConfig | None = None,
    out: Any = None,
    progress: bool = True,
    *,
    force: bool = False,
    provider: Any = None,
) -> RunResult:
    """Run the coverage mission of ``config`` and write its run folder.

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

    Returns
    -------
    RunResult
        Tables (``.to_frame()``), plots (``.plot()``), ``.summary``. If Ctrl-C stopped the run,
        ``.interrupted`` is true and the completed stages are kept (and written).

    Raises
    ------
    ConfigError
        An invalid configuration (the message names the field, the rule and the value).
    """
    from swarmgames.runfolder import RunFolder

    config = ScenarioConfig() if config is None else config
    if not isinstance(config, ScenarioConfig):
        raise TypeError(f"config must be a ScenarioConfig (got {type(config).__name__})")
    check_config(config)
    if out is not None and not isinstance(out, RunFolder):
        out = RunFolder(Path(out), force=force)
    t0 = time.perf_counter()
    potentials, model = build_mission(config)
    seeds = np.random.SeedSequence(config.seed).spawn(3)
    rng_start, rng_net, rng_game = (np.random.default_rng(s) for s in seeds)
    sw, sim = config.swarm, config.sim
    positions = start_positions(
        sw.n_robots, sw.start_center_m, sw.start_radius_m, sw.altitude_m, rng_start
    )
    if getattr(model, "state_dim", 3) > 3:  # velocity states start at rest
        extra = np.zeros((sw.n_robots, model.state_dim - 3))
        positions = np.hstack([positions, extra])
    if provider is None:
        from swarmgames.sim.providers import provider_from_config

        provider = provider_from_config(config.network, sw.n_robots, rng_net)
    ctrl_cls = GameController if sim.controller == "game" else LloydController
    controller = ctrl_cls(config, potentials, model)
    n_stages = max(1, int(np.floor(sim.duration_s / sim.control_period_s + 1e-9)))
    with _progress(progress, n_stages, config) as tick:
        log = run_stages(
            provider=provider,
            controller=controller,
            potentials=potentials,
            action_model=model,
            positions=positions,
            n_stages=n_stages,
            period_s=sim.control_period_s,
            warmup_s=sim.warmup_s,
            rng=rng_game,
            progress=tick,
        )
    result = RunResult.from_log(log, config, potentials.roi, time.perf_counter() - t0)
    if out is not None:
        result.write(out, animation=sim.animation, frames=sim.animation_frames)
    return result


class _progress:
    """A rich progress bar over the stages (or nothing)."""

    def __init__(self, enabled: bool, total: int, config: ScenarioConfig) -> None:
        self.enabled, self.total, self.config = enabled, total, config
        self.bar = None

    def __enter__(self):
        if not self.enabled:
            return None
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeElapsedColumn

        self.bar = Progress(
            "[progress.description]{task.description}",
            BarColumn(),
            MofNCompleteColumn(),
            TimeElapsedColumn(),
            transient=True,
        )
        self.bar.__enter__()
        c = self.config
        task = self.bar.add_task(
            f"{c.name}: {c.swarm.n_robots} robots, {c.network.backend}", total=self.total
        )
        return lambda done: self.bar.update(task, completed=done)

    def __exit__(self, *exc) -> None:
        if self.bar is not None:
            self.bar.__exit__(*exc)
