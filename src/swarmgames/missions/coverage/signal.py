"""Received-signal model of the coverage mission: log-distance path loss in dBm.

The paper (section III) scores a point ``r`` of the region of interest by the expected received
signal strength from a UAV,

.. math:: \\psi_R(d) = T_0 - \\bigl(L_0 + 10\\, n \\log_{10}(d / d_0)\\bigr),

with ``d`` the 3-D distance between the UAV (at its flight altitude) and the ground point, and
``d_0`` the reference distance at which the loss is ``L_0``. Distances below ``d_0`` are clamped
to ``d_0``: the far-field formula is not valid there and ``log10(0)`` would be ``-inf`` for
co-located robots.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop (arXiv 2205.02203), section III.
.. [2] ns-3 ``LogDistancePropagationLossModel``: exponent 3, reference distance 1 m,
   reference loss 46.6777 dB (docs/reference.md section 2).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["SignalModel"]


@dataclass(frozen=True)
class SignalModel:
    """Log-distance received power :math:`\\psi_R(d)` in dBm.

    Parameters
    ----------
    t0_dbm : float
        Transmit power T0, dBm.
    l0_db : float
        Loss at the reference distance L0, dB.
    exponent : float
        Path-loss exponent n (> 0).
    reference_distance_m : float
        Reference distance d0, metres (> 0); shorter distances are clamped to it.

    Examples
    --------
    >>> s = SignalModel(16.0206, 46.6777, 3.0)
    >>> round(float(s.power(10.0)), 4)
    -60.6571
    >>> float(s.power(0.0)) == float(s.power(1.0))   # clamped at d0 = 1 m
    True
    """

    t0_dbm: float = 16.0206
    l0_db: float = 46.6777
    exponent: float = 3.0
    reference_distance_m: float = 1.0

    def __post_init__(self) -> None:
        if not self.exponent > 0:
            raise ValueError(f"exponent must be > 0 (got {self.exponent})")
        if not self.reference_distance_m > 0:
            raise ValueError(f"reference_distance_m must be > 0 (got {self.reference_distance_m})")

    def power(self, d: np.ndarray | float, dtype=np.float64) -> np.ndarray:
        """:math:`\\psi_R(d)` in dBm for distances ``d`` in metres (any shape)."""
        d = np.maximum(np.asarray(d, dtype=dtype), dtype(self.reference_distance_m))
        return (self.t0_dbm - self.l0_db) - 10.0 * self.exponent * np.log10(
            d / dtype(self.reference_distance_m)
        )

    def power_sq(self, d2: np.ndarray, dtype=np.float32) -> np.ndarray:
        """:math:`\\psi_R` from *squared* distances (m²); saves a square root per cell:
        ``10 n log10(d) = 5 n log10(d²)``."""
        d02 = dtype(self.reference_distance_m) ** 2
        d2 = np.maximum(np.asarray(d2, dtype=dtype), d02)
        return dtype(self.t0_dbm - self.l0_db) - dtype(5.0 * self.exponent) * np.log10(d2 / d02)

    def field(self, uav_xyz: np.ndarray, ground_xy: np.ndarray, dtype=np.float32) -> np.ndarray:
        """Signal of every UAV at every ground point.

        Parameters
        ----------
        uav_xyz : ndarray, shape (U, 3)
            UAV positions (x, y, altitude), metres.
        ground_xy : ndarray, shape (G, 2)
            Ground points (z = 0), metres.

        Returns
        -------
        ndarray, shape (U, G)
            :math:`\\psi_R` in dBm, ``dtype`` (float32 by default: the signal is needed to a
            hundredth of a dB, far above float32's resolution).
        """
        u = np.asarray(uav_xyz, dtype=np.float64)
        g = np.asarray(ground_xy, dtype=np.float64)
        # Differences in float64 (positions can be kilometres away), then float32 powers.
        d2 = (
            (u[:, None, 0] - g[None, :, 0]) ** 2
            + (u[:, None, 1] - g[None, :, 1]) ** 2
            + u[:, None, 2] ** 2
        )
        return self.power_sq(d2.astype(dtype, copy=False), dtype=dtype)

    def link(self, a_xyz: np.ndarray, b_xyz: np.ndarray, dtype=np.float64) -> np.ndarray:
        """Signal between positions ``a`` and ``b`` (broadcast together, last axis 3)."""
        a = np.asarray(a_xyz, dtype=np.float64)
        b = np.asarray(b_xyz, dtype=np.float64)
        d2 = np.sum((a - b) ** 2, axis=-1)
        return self.power_sq(d2.astype(dtype, copy=False), dtype=dtype)
