"""The ``[coverage]`` section: the communication-aware coverage mission's parameters.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop (arXiv 2205.02203), section III, eqs. 5-6.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field, model_validator

from swarmgames.missions.coverage.roi import constant_density, grid_problem
from swarmgames.section import Coordinate, Section

__all__ = ["CoverageConfig"]


class CoverageConfig(Section):
    """Communication-aware coverage mission (paper section III, eqs. 5-6).

    Defaults where the paper is silent: an isotropic Gaussian ROI with sigma = 250 m (its 95 %
    ellipse has a 612 m radius, so 7 UAVs spread over it sit farther apart than one radio range
    of 368.84 m end to end and the network is multi-hop); a 20 m integration grid (about 2 900
    cells: payoff differences between 10 m moves are resolved while a stage stays fast); the
    signal model uses ns-3's log-distance defaults (T0 = 16.0206 dBm, L0 = 46.6777 dB at 1 m,
    n = 3), the exponent the authors' scripts used.

    ``area_per_robot_m2`` keeps the swarm's density whatever its size: the ROI covariance and
    the take-off disc are then derived from ``swarm.n_robots`` when the scenario is
    validated (:meth:`derive`), instead of being fixed numbers.

    ``move_cost_share_db`` and ``alpha_b_share`` state the move cost and the pairwise weight
    per UAV share of the ROI, so that they keep their balance against the coverage term
    whatever the swarm's size: eq. 5 integrates over the ROI's whole probability mass m, of
    which a UAV covers about m / N, so what one move gains falls as 1/N at constant density
    while a fixed move cost and a fixed link weight do not (docs/coverage.md, "What limits
    coverage at scale"). With them set, ``move_cost_db = move_cost_share_db / N`` and
    ``game.alpha_b = alpha_b_share / N`` are derived at validation (:meth:`derive`).
    """

    roi_mean_m: tuple[Coordinate, Coordinate] = Field(
        (0.0, 0.0), description="Mean of the Gaussian region of interest (x, y), metres."
    )
    roi_cov_m2: tuple[tuple[float, float], tuple[float, float]] = Field(
        ((62500.0, 0.0), (0.0, 62500.0)),
        description="Covariance of the Gaussian region of interest, square metres.",
    )
    area_per_robot_m2: float | None = Field(
        None,
        gt=0,
        description=(
            "ROI area per UAV: when set, the ROI is the isotropic Gaussian whose confidence "
            "disc has swarm.n_robots times this area, and the UAVs take off uniformly over "
            "that disc (swarm.start_center_m = roi_mean_m, swarm.start_radius_m = "
            "sqrt(n_robots * area / pi)), so changing swarm.n_robots keeps the density; "
            "mutually exclusive with roi_cov_m2, swarm.start_center_m and "
            "swarm.start_radius_m (None = those fixed values), square metres."
        ),
    )
    confidence: float = Field(
        0.95, gt=0, lt=1, description="Probability mass of the ROI concentration ellipse."
    )
    grid_cell_m: float = Field(20.0, gt=0, description="ROI integration grid cell size, metres.")
    t0_dbm: float = Field(16.0206, description="Signal model transmit power T0, dBm.")
    l0_db: float = Field(46.6777, description="Signal model reference loss L0, dB.")
    path_exponent: float = Field(3.0, gt=0, description="Signal model exponent n.")
    reference_distance_m: float = Field(
        1.0,
        gt=0,
        description="Signal model reference distance d0; shorter distances are clamped, metres.",
    )
    softness_db: float = Field(
        1.0,
        ge=0,
        description=(
            "Temperature of the smooth maximum tau*ln(e^(a/tau) + e^(b/tau)) used for eq. 5's "
            "max; not in the paper (0 = the hard max), dB."
        ),
    )
    separation_m: float = Field(
        50.0,
        ge=0,
        description=(
            "Distance below which a robot's next position is penalised for crowding another "
            "robot (not in the paper; 0 = off), metres."
        ),
    )
    separation_cost_db: float = Field(
        0.1,
        ge=0,
        description=(
            "Weight of the crowding penalty, dB of expected ROI signal at zero distance "
            "(not in the paper; 0 = off), dB."
        ),
    )
    separation_mode: Literal["pairwise", "unary"] = Field(
        "pairwise",
        description=(
            "How the crowding penalty sees the other robots: 'pairwise' = a pairwise potential "
            "on both robots' next positions (the local game predicts both moves), 'unary' = "
            "the robot's next position against the others' current positions (each assumes "
            "the others stay; co-located robots can then oscillate in lockstep); no unit."
        ),
    )
    move_cost_db: float = Field(
        0.01,
        ge=0,
        description=(
            "Cost of one move in the unary potential, dB of expected ROI signal; not in the "
            "paper (0 = eq. 5 exactly); a small cost lets the swarm settle, dB."
        ),
    )

    move_cost_share_db: float | None = Field(
        None,
        ge=0,
        description=(
            "Move cost per UAV share of the ROI: when set, move_cost_db = this / "
            "swarm.n_robots (a UAV's share of the ROI mass is 1/N of it, and so is what one "
            "of its moves gains), so the cost keeps its balance against a move's gain at any "
            "swarm size; mutually exclusive with move_cost_db (None = move_cost_db as given), "
            "dB."
        ),
    )
    alpha_b_share: float | None = Field(
        None,
        ge=0,
        description=(
            "Pairwise weight per UAV share of the ROI: when set, game.alpha_b = this / "
            "swarm.n_robots, so the link term of eq. 6 keeps its balance against a move's "
            "coverage gain at any swarm size; mutually exclusive with game.alpha_b (None = "
            "game.alpha_b as given); no unit."
        ),
    )

    signal_floor_dbm: float | None = Field(
        None,
        description=(
            "Level below which a signal no longer counts in eq. 5 (signals are clamped to it), "
            "so a UAV's unary is integrated only over the grid cells within the radius where "
            "its signal reaches the floor; for large swarms (None = the whole ROI, the paper), "
            "dBm."
        ),
    )

    kernel: Literal["auto", "compiled", "numpy"] = Field(
        "auto",
        description=(
            "How the unary is integrated under a signal floor: 'compiled' = one fused Numba "
            "kernel per variable, 'numpy' = numpy passes over (variables x actions x cells) "
            "blocks, 'auto' = compiled when Numba is installed; the two agree to float32 "
            "rounding."
        ),
    )

    workers: int = Field(
        1,
        ge=1,
        le=64,
        description=(
            "Threads integrating the unary under a signal floor (the compiled kernel's or "
            "numpy's, which release the GIL; the result does not depend on it)."
        ),
    )

    link_term: Literal["signal", "at_risk", "keep", "off"] = Field(
        "signal",
        description=(
            "The pairwise term: 'signal' = eq. 6, the link quality psi_R between every pair's "
            "next positions (a pull towards every neighbour); 'at_risk' = the received-power "
            "shortfall below network.radio.rx_threshold_dbm + link_margin_db of the pairs "
            "linked now that a move adds, weighted by link_cost_db (zero on links with margin "
            "to spare); 'keep' = each robot keeps within the disc around the midpoint of each "
            "of its relative neighbour links (linked pairs that no third known robot is "
            "closer to) that keeps the link whatever the neighbour does, a hard constraint in "
            "the unary (the pairwise term is the crowding penalty alone); 'off' = no link term "
            "(the pairwise term is the crowding penalty alone); no unit."
        ),
    )
    link_cost_db: float = Field(
        0.1,
        gt=0,
        description=(
            "With link_term = 'at_risk': what one dB of shortfall on one link costs, in dB of "
            "expected ROI signal (like move_cost_db), dB per dB."
        ),
    )
    link_margin_db: float = Field(
        3.0,
        ge=0,
        description=(
            "With link_term = 'at_risk': the power above the reception threshold a link "
            "should keep, dB."
        ),
    )

    @model_validator(mode="after")
    def _covariance_positive_definite(self) -> CoverageConfig:
        if self.area_per_robot_m2 is not None:  # the covariance is derived: see derive()
            return self
        (a, b), (c, d) = self.roi_cov_m2
        if b != c or a <= 0 or a * d - b * c <= 0:
            raise ValueError(
                f"roi_cov_m2 must be symmetric positive definite (got {self.roi_cov_m2})"
            )
        problem = grid_problem(
            self.roi_cov_m2, self.confidence, self.grid_cell_m, name="grid_cell_m"
        )
        if problem is not None:
            raise ValueError(problem)
        return self

    def check_scenario(self, scenario) -> None:
        """The pairwise crowding penalty and the link term at risk are weighted by
        ``game.alpha_b`` (given, or derived from ``alpha_b_share``), which must be > 0."""
        if self.link_term == "at_risk" and scenario.game.alpha_b == 0:
            raise ValueError(
                "game.alpha_b must be > 0 for the link term at risk "
                "(coverage.link_term = 'at_risk') (got game.alpha_b = 0); set "
                "coverage.link_term = 'signal' or game.alpha_b > 0"
            )
        crowding = self.separation_m > 0 and self.separation_cost_db > 0
        if crowding and self.separation_mode == "pairwise" and scenario.game.alpha_b == 0:
            given = (
                "game.alpha_b = 0"
                if self.alpha_b_share is None
                else "game.alpha_b = 0 from coverage.alpha_b_share = 0"
            )
            raise ValueError(
                "game.alpha_b must be > 0 for the pairwise crowding penalty "
                f"(coverage.separation_mode = 'pairwise') (got {given}); set "
                "coverage.separation_mode = 'unary' or coverage.separation_cost_db = 0"
            )

    def derive(self, scenario) -> dict[str, dict[str, Any]]:
        """The fields that follow from ``swarm.n_robots``: with ``area_per_robot_m2`` set,
        the ROI covariance and the take-off disc of N UAVs at that density
        (:func:`~swarmgames.missions.coverage.roi.constant_density`); with
        ``move_cost_share_db`` or ``alpha_b_share`` set, ``move_cost_db`` or ``game.alpha_b``
        (that share divided by N); nothing otherwise.

        Raises
        ------
        ValueError
            One of the derived fields was also given, or the derived ROI cannot be gridded
            with ``grid_cell_m``.
        """
        derived = self._derive_density(scenario)
        n = scenario.swarm.n_robots
        if self.move_cost_share_db is not None:
            share = self.move_cost_share_db
            _refuse_given("move_cost_share_db", share, self, "coverage.move_cost_db")
            derived.setdefault("mission", {})["move_cost_db"] = share / n
        if self.alpha_b_share is not None:
            share = self.alpha_b_share
            _refuse_given("alpha_b_share", share, scenario.game, "game.alpha_b")
            derived["game"] = {"alpha_b": share / n}
        return derived

    def _derive_density(self, scenario) -> dict[str, dict[str, Any]]:
        """The ROI covariance and the take-off disc of ``area_per_robot_m2`` (see
        :meth:`derive`)."""
        if self.area_per_robot_m2 is None:
            return {}
        given = [
            (f"coverage.{f}", getattr(self, f))
            for f in ("roi_cov_m2",)
            if f in self.model_fields_set
        ]
        given += [
            (f"swarm.{f}", getattr(scenario.swarm, f))
            for f in ("start_center_m", "start_radius_m")
            if f in scenario.swarm.model_fields_set
        ]
        if given:
            names = " and ".join(path for path, _ in given)
            values = ", ".join(f"{path} = {_plain(value)}" for path, value in given)
            raise ValueError(
                "coverage.area_per_robot_m2 derives coverage.roi_cov_m2, swarm.start_center_m "
                "and swarm.start_radius_m from swarm.n_robots, so it is mutually exclusive "
                f"with them: remove {names}, or coverage.area_per_robot_m2 (got "
                f"coverage.area_per_robot_m2 = {self.area_per_robot_m2:g}, {values})"
            )
        n = scenario.swarm.n_robots
        sigma2, radius = constant_density(n, self.area_per_robot_m2, self.confidence)
        cov = ((sigma2, 0.0), (0.0, sigma2))
        problem = grid_problem(cov, self.confidence, self.grid_cell_m, name="grid_cell_m")
        if problem is not None:
            raise ValueError(
                f"the ROI of coverage.area_per_robot_m2 = {self.area_per_robot_m2:g} m2 for "
                f"swarm.n_robots = {n}: coverage.{problem}"
            )
        return {
            "mission": {"roi_cov_m2": cov},
            "swarm": {"start_center_m": tuple(self.roi_mean_m), "start_radius_m": radius},
        }


def _refuse_given(name: str, share: float, section, path: str) -> None:
    """Raise ``ValueError`` when the field at ``path`` (in ``section``), which
    ``coverage.<name>`` derives, was also given."""
    field = path.split(".")[1]
    if field in section.model_fields_set:
        raise ValueError(
            f"coverage.{name} derives {path} from swarm.n_robots, so it is mutually exclusive "
            f"with it: remove {path}, or coverage.{name} (got coverage.{name} = {share:g}, "
            f"{path} = {getattr(section, field):g})"
        )


def _plain(value: Any) -> str:
    """A configuration value as it reads in a scenario file (tuples as lists)."""
    if isinstance(value, tuple):
        return "[" + ", ".join(_plain(v) for v in value) + "]"
    return f"{value:g}" if isinstance(value, float) else repr(value)
