"""The communication-aware coverage mission (paper section III): a Gaussian region of interest
(:class:`GaussianROI`), the log-distance signal :math:`\\psi_R` (:class:`SignalModel`), the
potentials of eqs. 5-6 (:class:`CoveragePotentials`), its ``[coverage]`` section
(:class:`CoverageConfig`), the mission (:class:`CoverageMission`) and the Lloyd/Voronoi
baseline (:func:`lloyd_actions`)."""

from swarmgames.missions.coverage.config import CoverageConfig
from swarmgames.missions.coverage.lloyd import lloyd_actions, voronoi_centroids
from swarmgames.missions.coverage.mission import CoverageMission
from swarmgames.missions.coverage.potentials import CoveragePotentials
from swarmgames.missions.coverage.roi import GaussianROI
from swarmgames.missions.coverage.signal import SignalModel

__all__ = [
    "CoverageConfig",
    "CoverageMission",
    "CoveragePotentials",
    "GaussianROI",
    "SignalModel",
    "lloyd_actions",
    "voronoi_centroids",
]
