"""One full stage of the coverage mission, ready to be timed at any swarm size.

A stage is what the simulation loop does once per control period
(:func:`swarmgames.sim.loop.run_stages`): advance the network provider by one period with the
robots at their current positions, build and solve every robot's local game (integration of
the potentials included), and move every robot. :class:`StageBench` holds the state of a
mission between stages so that :func:`~swarmgames.bench.timing.measure` can call
:meth:`StageBench.step` repeatedly; the scenario is a constant-density one
(:func:`~swarmgames.scenarios.scaling.scaled_config`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from swarmgames.config import ScenarioConfig
from swarmgames.scenarios.scaling import scaled_config
from swarmgames.sim.controllers import GameController
from swarmgames.sim.loop import start_positions
from swarmgames.sim.providers import provider_from_config
from swarmgames.sim.runner import build_mission

__all__ = ["StageBench", "StageParts"]


@dataclass
class StageParts:
    """Wall time of the parts of the stages run so far, seconds per stage (lists)."""

    advance_s: list[float] = field(default_factory=list)
    integrate_s: list[float] = field(default_factory=list)
    solve_s: list[float] = field(default_factory=list)
    decide_s: list[float] = field(default_factory=list)
    motion_s: list[float] = field(default_factory=list)
    neighbours: list[float] = field(default_factory=list)

    def medians(self) -> dict[str, float]:
        """Median of every part (NaN when no stage ran)."""
        return {
            name: float(np.median(vals)) if vals else float("nan")
            for name, vals in self.__dict__.items()
        }


class StageBench:
    """A coverage mission of ``n_robots`` UAVs, stepped one stage at a time.

    Parameters
    ----------
    n_robots : int
    config : ScenarioConfig, optional
        Default: :func:`scaled_config` of ``n_robots`` (constant density); the run's global
        regret measurement is switched off (it is a metric, not part of a stage).
    seed : int
        Seed of the start positions, the network and the game.
    workers : int
        Threads of the windowed integral (``coverage.workers``) of the default scenario.
    workers : int
        Threads of the windowed integral (``coverage.workers``) of the default scenario.

    Attributes
    ----------
    setup_s : float
        Wall time of building the mission and warming up the network, seconds.
    parts : StageParts
    """

    def __init__(
        self,
        n_robots: int,
        config: ScenarioConfig | None = None,
        seed: int = 0,
        *,
        workers: int = 1,
    ) -> None:
        t0 = time.perf_counter()
        cfg = scaled_config(n_robots, workers=workers) if config is None else config
        self.config = cfg.model_copy(
            update={"sim": cfg.sim.model_copy(update={"global_regret": False})}
        )
        self.potentials, self.model = build_mission(self.config)
        rng_start, rng_net, self.rng = (
            np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(3)
        )
        sw, sim = self.config.swarm, self.config.sim
        self.positions = start_positions(
            sw.n_robots, sw.start_center_m, sw.start_radius_m, sw.altitude_m, rng_start
        )
        self.provider: Any = provider_from_config(self.config.network, sw.n_robots, rng_net)
        self.provider.reset(self.positions, 0.0)
        self.time = sim.warmup_s
        self.snapshot = self.provider.advance(self.time, self.positions)
        self.controller = GameController(self.config, self.potentials, self.model)
        self.parts = StageParts()
        self._rows = np.arange(sw.n_robots)
        self.setup_s = time.perf_counter() - t0

    @property
    def n_robots(self) -> int:
        """N."""
        return int(self._rows.size)

    def step(self) -> None:
        """One stage: network advance, every local game, motion."""
        period = self.config.sim.control_period_s
        t0 = time.perf_counter()
        self.time += period
        self.snapshot = self.provider.advance(self.time, self.positions[:, :3])
        t1 = time.perf_counter()
        dec = self.controller.decide(self.snapshot, self.positions, self.rng)
        t2 = time.perf_counter()
        self.positions = self.model.apply(self.positions)[self._rows, dec.actions]
        t3 = time.perf_counter()
        n = self.n_robots
        p = self.parts
        p.advance_s.append(t1 - t0)
        p.decide_s.append(t2 - t1)
        p.motion_s.append(t3 - t2)
        p.integrate_s.append(float(dec.integrate_ms[0]) * n / 1e3)
        p.solve_s.append(float(dec.solve_ms[0]) * n / 1e3)
        p.neighbours.append(float(np.mean(dec.neighbours)))
