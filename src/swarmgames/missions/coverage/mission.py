"""The communication-aware coverage mission as a :class:`~swarmgames.missions.Mission`.

The UAVs take off from a common disc and spread over a Gaussian region of interest (ROI) to
maximise the expected best signal a ground point receives (paper section III). The stage
game's potentials are eqs. 5-6 (:class:`~swarmgames.missions.coverage.potentials.
CoveragePotentials`) plus the move cost as :class:`~swarmgames.game.inertia.Inertia`; the
per-stage metric is ``coverage``, :math:`E[\\max_i \\psi_R(S_i, r) \\mid r \\in \\mathcal{R}]`
in dBm, with the hard maximum whatever the potentials use.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop (arXiv 2205.02203), section III, eqs. 5-6.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np

from swarmgames.errors import ConfigError
from swarmgames.game.inertia import Inertia
from swarmgames.missions.coverage.config import CoverageConfig
from swarmgames.missions.coverage.links import LinkKeeping, LinkRisk
from swarmgames.missions.coverage.lloyd import lloyd_actions
from swarmgames.missions.coverage.potentials import CoveragePotentials
from swarmgames.missions.coverage.roi import GaussianROI
from swarmgames.missions.coverage.signal import SignalModel
from swarmgames.missions.motion import TakeOff, arena_for, uav_actions
from swarmgames.missions.protocol import Baseline
from swarmgames.missions.registry import MissionEntry
from swarmgames.network.parameters import RadioParameters

__all__ = ["ENTRY", "CoverageMission", "build"]


@dataclass(frozen=True, eq=False)
class CoverageMission:
    """Coverage of ``roi`` by UAVs taking off from a disc.

    Parameters
    ----------
    potentials : Potentials
        The game's potentials (``CoveragePotentials``, usually wrapped in ``Inertia``).
    action_model : HeadingActions or AccelerationActions
    roi : GaussianROI
    takeoff : TakeOff
        The take-off disc.
    """

    potentials: Any
    action_model: Any
    roi: GaussianROI
    takeoff: TakeOff
    name: str = "coverage"

    @property
    def state_dim(self) -> int:
        """D: 3 for heading moves, 5 for acceleration labels (velocities)."""
        return int(self.action_model.state_dim)

    @property
    def baselines(self) -> dict[str, Baseline]:
        """``"lloyd"``: Lloyd/Voronoi coverage of the ROI with the mission's actions
        (:func:`~swarmgames.missions.coverage.lloyd.lloyd_actions`)."""
        return {"lloyd": partial(lloyd_actions, roi=self.roi, action_model=self.action_model)}

    def initial_states(self, n_robots: int, rng: np.random.Generator) -> np.ndarray:
        """Uniform over the take-off disc at the flight altitude, at rest."""
        return self.takeoff.states(n_robots, rng, self.state_dim)

    def swarm_metrics(
        self, states: np.ndarray, previous: np.ndarray | None, t: float
    ) -> dict[str, float]:
        """``coverage``: the ROI's expected best signal, dBm (the ROI does not move: ``t``
        is not read)."""
        return {"coverage": self._coverage().coverage(states)}

    def moves_undone(self, states: np.ndarray, previous: np.ndarray, t: float) -> np.ndarray | None:
        """``coverage`` with each robot's move undone in turn, (N,) dBm
        (:meth:`~swarmgames.missions.coverage.potentials.CoveragePotentials.
        coverage_moves_undone`)."""
        return self._coverage().coverage_moves_undone(states, previous)

    def summary(self, times: np.ndarray, swarm: dict[str, np.ndarray]) -> dict[str, Any]:
        """Coverage at the first and the last stage, dBm."""
        cov = swarm.get("coverage", np.zeros(0))
        first, last = (float(cov[0]), float(cov[-1])) if len(cov) else (None, None)
        return {"coverage_start_dbm": first, "coverage_end_dbm": last}

    def draw(self, ax) -> None:
        """Shade the ROI density and outline its concentration ellipse."""
        from swarmgames.missions.coverage.plots import draw_roi

        draw_roi(ax, self.roi)

    def extent(self) -> tuple[float, float, float, float]:
        """The ROI's bounding box ``(xmin, xmax, ymin, ymax)``, metres."""
        return self.roi.bounding_box()

    def _coverage(self) -> CoveragePotentials:
        pot = self.potentials
        return pot.potentials if isinstance(pot, Inertia) else pot


def build(config) -> CoverageMission:
    """The coverage mission of a :class:`~swarmgames.config.ScenarioConfig`.

    Raises
    ------
    ConfigError
        A combination of ``[coverage]`` and ``[game]`` the potentials cannot use (the message
        names the fields).
    """
    cov: CoverageConfig = config.mission
    signal = SignalModel(cov.t0_dbm, cov.l0_db, cov.path_exponent, cov.reference_distance_m)
    try:
        roi = GaussianROI(cov.roi_mean_m, cov.roi_cov_m2, cov.confidence, cov.grid_cell_m)
        base = CoveragePotentials(
            roi,
            signal,
            softness_db=cov.softness_db,
            separation_m=cov.separation_m,
            separation_cost_db=cov.separation_cost_db,
            signal_floor_dbm=cov.signal_floor_dbm,
            workers=cov.workers,
            kernel=cov.kernel,
            separation_mode=cov.separation_mode,
            alpha_b=config.game.alpha_b,
            link_term=cov.link_term,
            link_risk=LinkRisk(
                RadioParameters(**config.network.radio.model_dump()), cov.link_margin_db
            )
            if cov.link_term == "at_risk"
            else None,
            link_keep=LinkKeeping(RadioParameters(**config.network.radio.model_dump()))
            if cov.link_term == "keep"
            else None,
            link_cost_db=cov.link_cost_db,
        )
    except ValueError as exc:
        raise ConfigError(f"coverage: {exc}") from None
    potentials = Inertia(base, cov.move_cost_db * roi.mass) if cov.move_cost_db else base
    sw = config.swarm
    takeoff = TakeOff.of(sw)
    bounds = arena_for(roi, takeoff.center_m, takeoff.radius_m, sw.arena_margin_m)
    return CoverageMission(
        potentials=potentials,
        action_model=uav_actions(sw, config.sim.control_period_s, bounds),
        roi=roi,
        takeoff=takeoff,
    )


#: The registry entry of the built-in ``coverage`` mission.
ENTRY = MissionEntry(
    name="coverage",
    config=CoverageConfig,
    build=build,
    description="communication-aware coverage of a Gaussian region of interest (the paper's)",
    baselines=("lloyd",),
)
