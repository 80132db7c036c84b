"""Scenarios: missions expressed as potentials of the stage graphical game.

The communication-aware coverage mission of the paper (section III): a Gaussian region of
interest (:class:`GaussianROI`), the log-distance signal :math:`\\psi_R`
(:class:`SignalModel`), the unary and pairwise potentials of eqs. 4-5
(:class:`CoveragePotentials`) and the UAV action set (:class:`HeadingActions`);
:func:`scaled_config` builds the mission for any swarm size at constant density.
"""

from swarmgames.scenarios.coverage import CoveragePotentials
from swarmgames.scenarios.motion import AccelerationActions, HeadingActions, arena_for
from swarmgames.scenarios.roi import GaussianROI
from swarmgames.scenarios.scaling import scaled_config
from swarmgames.scenarios.signal import SignalModel

__all__ = [
    "AccelerationActions",
    "CoveragePotentials",
    "GaussianROI",
    "HeadingActions",
    "SignalModel",
    "arena_for",
    "scaled_config",
]
