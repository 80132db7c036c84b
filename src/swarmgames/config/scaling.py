"""Constant-density scenarios: the coverage mission for any swarm size.

To measure how the cost of a stage grows with the number of UAVs N, the mission must stay the
same per UAV: the ROI grows with N so that every UAV has the same area to cover, the
integration grid keeps its cell size, and the UAVs start spread over the ROI (a take-off disc
of 10 000 UAVs would be one clique). :func:`scaled_config` builds such a scenario on
the ``coverage.area_per_robot_m2`` setting, which derives the ROI and the take-off disc from
the swarm size whenever the configuration is validated (so ``with_overrides({"swarm.n_robots":
n})`` of its result, or ``swarmgames run coverage-large --set swarm.n_robots=n``, keeps the
density; :func:`swarmgames.missions.coverage.roi.constant_density`).

The isotropic ROI :math:`\\mathcal{N}(\\mu, \\sigma^2 I)` at confidence ``c`` is the disc of
radius :math:`r = \\sigma\\sqrt{k^2}`, :math:`k^2 = -2\\ln(1 - c)`; holding
:math:`\\pi r^2 = N a` (``a`` the area per UAV) gives

.. math:: \\sigma^2 = \\frac{N a}{\\pi k^2}.

The default ``a`` = 70 000 m² gives every UAV about six radio neighbours within the
368.84 m range of the 802.11a link (:math:`\\pi\\, 368.84^2 / a \\approx 6.1`; docs/reference.md
section 2), and 175 grid cells of 20 m. The default signal floor, -100 dBm, is the signal at
about 205 m from a UAV at 30 m altitude, farther than any ROI point lies from its nearest UAV
once the swarm is spread at this density (hexagonal spacing 284 m, farthest point 164 m): it
cuts off only what the swarm leaves uncovered anyway, and bounds each UAV's integral to a disc
of about 400 cells.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop (arXiv 2205.02203), section III.
"""

from __future__ import annotations

import math

from swarmgames.config.io import parse_config, to_data
from swarmgames.config.schema import ScenarioConfig

__all__ = ["scaled_config"]


def scaled_config(
    n_robots: int,
    *,
    area_per_robot_m2: float = 70_000.0,
    signal_floor_dbm: float | None = -100.0,
    backend: str = "olsr",
    workers: int = 1,
    base: ScenarioConfig | None = None,
) -> ScenarioConfig:
    """A coverage scenario for ``n_robots`` UAVs at constant density.

    Parameters
    ----------
    n_robots : int
        N, >= 1.
    area_per_robot_m2 : float, default 70 000
        ROI area per UAV, square metres (> 0); the ROI's area is ``n_robots`` times this.
    signal_floor_dbm : float or None, default -100
        ``coverage.signal_floor_dbm`` (None: integrate over the whole ROI, the paper's model,
        whose cost grows as N²).
    backend : str, default "olsr"
        ``network.backend``.
    workers : int, default 1
        ``coverage.workers``, threads of the windowed integral.
    base : ScenarioConfig, optional
        Other settings (default: ``ScenarioConfig()``); its ROI, start area, swarm size,
        floor and backend are replaced.

    Returns
    -------
    ScenarioConfig
        ``coverage.area_per_robot_m2 = area_per_robot_m2``: the ROI centred at the origin, the
        UAVs starting uniformly over the ROI's disc; payoff tables in float32
        (``game.dtype``).

    Raises
    ------
    ValueError
        ``n_robots < 1`` or ``area_per_robot_m2 <= 0``.

    Examples
    --------
    >>> cfg = scaled_config(1000)
    >>> round(cfg.swarm.start_radius_m)      # sqrt(1000 * 70 000 / pi)
    4720
    """
    if isinstance(n_robots, bool) or not isinstance(n_robots, int) or n_robots < 1:
        raise ValueError(f"n_robots must be an integer >= 1 (got {n_robots!r})")
    if not (math.isfinite(area_per_robot_m2) and area_per_robot_m2 > 0):
        raise ValueError(f"area_per_robot_m2 must be > 0 (got {area_per_robot_m2})")
    base = ScenarioConfig() if base is None else base
    if base.scenario != "coverage":
        raise ValueError(f"base must be a coverage scenario (got scenario = {base.scenario!r})")
    data = to_data(base)
    # The ROI and the take-off disc follow from coverage.area_per_robot_m2 at validation.
    for section, fields in (("swarm", DERIVED_START), ("coverage", ("roi_cov_m2",))):
        for name in fields:
            data[section].pop(name, None)
    data["swarm"]["n_robots"] = n_robots
    data["coverage"].update(
        area_per_robot_m2=area_per_robot_m2,
        roi_mean_m=[0.0, 0.0],
        signal_floor_dbm=signal_floor_dbm,
        workers=workers,
    )
    data["network"]["backend"] = backend
    data["game"]["dtype"] = "float32"
    data["name"] = f"{base.name}-n{n_robots}"
    return parse_config(data, source="scaled_config")


#: The take-off fields ``coverage.area_per_robot_m2`` derives.
DERIVED_START = ("start_center_m", "start_radius_m")
