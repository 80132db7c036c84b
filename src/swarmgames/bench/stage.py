"""One full stage of the coverage mission, ready to be timed at any swarm size.

A stage is what the simulation loop does once per control period
(:func:`swarmgames.sim.loop.run_stages`): advance the network provider by one period with the
robots at their current positions, build and solve every robot's local game (integration of
the potentials included), and move every robot. :class:`StageBench` holds the state of a
mission between stages so that :func:`~swarmgames.bench.timing.measure` can call
:meth:`StageBench.step` repeatedly; the scenario is a constant-density one
(:func:`~swarmgames.config.scaling.scaled_config`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from swarmgames.config import ScenarioConfig, scaled_config
from swarmgames.game.local import broadcast
from swarmgames.game.problem import StageProblem
from swarmgames.sim.controllers import GameController
from swarmgames.sim.providers import provider_from_config
from swarmgames.sim.runner import build_mission

__all__ = ["StageBench", "StageParts"]


@dataclass
class StageParts:
    """Wall time of the parts of the stages run so far, seconds per stage (lists), and the
    mean neighbourhood size and mean-field sweeps per game of each stage."""

    advance_s: list[float] = field(default_factory=list)
    integrate_s: list[float] = field(default_factory=list)
    solve_s: list[float] = field(default_factory=list)
    decide_s: list[float] = field(default_factory=list)
    neighbours: list[float] = field(default_factory=list)
    iterations: list[float] = field(default_factory=list)

    def medians(self) -> dict[str, float]:
        """Median of every part (NaN when no stage ran)."""
        return {
            name: float(np.median(vals)) if vals else float("nan")
            for name, vals in self.__dict__.items()
        }


class StageBench:
    """A mission of ``n_robots`` UAVs (default: coverage at constant density), stepped one
    stage at a time with the run's own controller.

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
        self.config = cfg.with_overrides({"sim.global_regret": False})
        self.mission = build_mission(self.config)
        rng_start, rng_net, self.rng = (
            np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(3)
        )
        sw, sim = self.config.swarm, self.config.sim
        self.states = self.mission.initial_states(sw.n_robots, rng_start)
        self.provider: Any = provider_from_config(self.config.network, sw.n_robots, rng_net)
        self.provider.reset(self.states[:, :3], 0.0)
        self.time = sim.warmup_s
        self.snapshot = self.provider.advance(self.time, self.states[:, :3])
        self.controller = GameController(self.config, self.mission)
        self.parts = StageParts()
        self.setup_s = time.perf_counter() - t0

    @property
    def n_robots(self) -> int:
        """N."""
        return int(self.states.shape[0])

    def problem(self, *, keep_games: bool = False) -> StageProblem:
        """The current stage's problem with exact, instant delivery (the run's controller's
        options)."""
        messages = broadcast(self.snapshot, self.controller.hops, self.states)
        return self.controller.problem(
            self.time, self.snapshot, self.states, messages, keep_games=keep_games
        )

    def step(self) -> None:
        """One stage: network advance, every local game solved, the robots moved."""
        period = self.config.sim.control_period_s
        t0 = time.perf_counter()
        self.time += period
        self.snapshot = self.provider.advance(self.time, self.states[:, :3])
        t1 = time.perf_counter()
        dec = self.controller.decide(self.problem(), self.rng)
        self.states = np.asarray(dec.next_states)
        t2 = time.perf_counter()
        p = self.parts
        p.advance_s.append(t1 - t0)
        p.decide_s.append(t2 - t1)
        p.integrate_s.append(dec.integrate_s)
        p.solve_s.append(dec.solve_s)
        p.neighbours.append(float(np.mean(dec.neighbours)))
        p.iterations.append(float(np.mean(dec.iterations)))
