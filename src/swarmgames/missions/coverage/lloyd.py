"""Lloyd/Voronoi coverage baseline: every robot heads for the centroid of its Voronoi cell.

Lloyd's algorithm, the classic coverage controller (Cortes et al. 2004, as in CoverageControl),
moves each robot toward the density-weighted centroid of its Voronoi cell,

.. math:: c_i = \\frac{\\int_{V_i \\cap \\mathcal{R}} r\\, p(r)\\, dr}
                     {\\int_{V_i \\cap \\mathcal{R}} p(r)\\, dr},
          \\qquad V_i = \\{ r : \\|r - s_i\\| \\le \\|r - s_j\\|\\ \\forall j \\},

computed here on the ROI grid (cells assigned to the nearest robot with a KD-tree). Each robot
then takes the action of the discrete action set that brings it closest to its centroid, so the
baseline moves exactly like the game controller. A robot whose cell holds no ROI cell (it is
far outside) heads for the ROI's mean. It assumes every robot knows every position: it is a
centralised, network-oblivious reference, not a decentralised controller.

References
----------
.. [1] J. Cortes, S. Martinez, T. Karatas, F. Bullo, "Coverage control for mobile sensing
   networks", IEEE Trans. Robotics and Automation 20(2), 2004.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["lloyd_actions", "voronoi_centroids"]


def voronoi_centroids(positions: np.ndarray, roi) -> np.ndarray:
    """Density-weighted centroids of the robots' Voronoi cells within the ROI, shape (N, 2).

    Robots whose cell holds no grid cell get the ROI mean.
    """
    xy = np.asarray(positions, dtype=float)[:, :2]
    n = xy.shape[0]
    _, owner = cKDTree(xy).query(roi.points)
    mass = np.bincount(owner, weights=roi.weights, minlength=n)
    cx = np.bincount(owner, weights=roi.weights * roi.points[:, 0], minlength=n)
    cy = np.bincount(owner, weights=roi.weights * roi.points[:, 1], minlength=n)
    out = np.tile(np.asarray(roi.mean, dtype=float), (n, 1))
    has = mass > 0
    out[has, 0] = cx[has] / mass[has]
    out[has, 1] = cy[has] / mass[has]
    return out


def lloyd_actions(positions: np.ndarray, roi, action_model) -> np.ndarray:
    """Each robot's valid action whose next position is nearest its Voronoi centroid, (N,).

    Ties go to the lowest action index ("stay" first), so a robot at its centroid stays.
    """
    pos = np.asarray(positions, dtype=float)
    target = voronoi_centroids(pos, roi)
    nxt = action_model.apply(pos)  # (N, A, 3)
    dist = np.linalg.norm(nxt[..., :2] - target[:, None, :], axis=-1)
    valid = getattr(action_model, "valid", None)
    if valid is not None:
        dist = np.where(valid(pos), dist, np.inf)
    # Stay unless a move gets strictly closer (by more than float noise).
    dist[:, 1:] = np.where(dist[:, 1:] < dist[:, :1] - 1e-9, dist[:, 1:], np.inf)
    return np.argmin(dist, axis=1).astype(np.int64)
