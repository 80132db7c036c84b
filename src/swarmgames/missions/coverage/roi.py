"""Region of interest: the concentration ellipse of a bivariate Gaussian, on a grid.

The ROI of the paper's coverage experiment (section III) is the concentration ellipse
:math:`\\mathcal{R} = \\{ r : (r - \\mu)^\\top \\Sigma^{-1} (r - \\mu) \\le k^2 \\}` of a
bivariate Gaussian :math:`\\mathcal{N}(\\mu, \\Sigma)`, with :math:`k^2 = \\chi^2_2(c)` the
quantile of the chi-squared law with 2 degrees of freedom at confidence ``c``; for two
dimensions it has the closed form :math:`k^2 = -2 \\ln(1 - c)`, so the ellipse holds
probability mass exactly ``c``.

Integrals over the ROI, :math:`\\int_\\mathcal{R} f(r)\\, p(r)\\, dr`, are midpoint sums over
the centres of the square cells of a regular grid that fall inside the ellipse, each weighted
by :math:`p(r_g)\\, a^2` (``a`` the cell size). The weights sum to ``c`` up to the
discretisation error, which shrinks as :math:`O(a^2)`.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop (arXiv 2205.02203), section III.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from swarmgames.arrays import frozen

__all__ = ["MAX_CELLS", "GaussianROI", "constant_density", "grid_problem"]


#: Most grid cells of the ROI's bounding box (4 M cells: 64 MB per float32 field row).
MAX_CELLS = 4_000_000


def grid_problem(
    cov, confidence: float, cell_m: float, max_cells: int = MAX_CELLS, name: str = "cell_m"
) -> str | None:
    """Why cells of ``cell_m`` cannot grid the ROI of ``cov`` at ``confidence``, or None.

    The cell must be at most the ellipse's shortest semi-axis, and the bounding box may hold
    at most ``max_cells`` cells; ``name`` is the parameter the message names (the
    configuration says ``coverage.grid_cell_m``).

    Examples
    --------
    >>> grid_problem(((62500.0, 0.0), (0.0, 62500.0)), 0.95, 1000.0, name="grid_cell_m")
    "grid_cell_m must be <= the ROI's shortest semi-axis, 611.9 m (got 1000.0)"
    """
    cov = np.asarray(cov, dtype=float)
    k2 = -2.0 * np.log1p(-confidence)
    shortest = float(np.sqrt(k2 * np.linalg.eigvalsh(cov)[0]))
    if cell_m > shortest:
        return f"{name} must be <= the ROI's shortest semi-axis, {shortest:.1f} m (got {cell_m})"
    n_axis = np.ceil(2.0 * np.sqrt(k2 * np.diag(cov)) / cell_m)
    cells = float(np.prod(n_axis))
    if cells > max_cells:
        return (
            f"{name} = {cell_m} m gives about {int(cells):,} grid cells, more than "
            f"{max_cells:,}; choose a larger cell (got {cell_m})"
        )
    return None


def constant_density(
    n_robots: int, area_per_robot_m2: float, confidence: float
) -> tuple[float, float]:
    """The isotropic ROI and the start disc that give every one of ``n_robots`` UAVs the
    same area: ``(sigma2, radius)``.

    The ROI :math:`\\mathcal{N}(\\mu, \\sigma^2 I)` at confidence ``c`` is the disc of radius
    :math:`\\sigma\\sqrt{k^2}`, :math:`k^2 = -2\\ln(1 - c)`; holding its area at
    :math:`N a` gives :math:`\\sigma^2 = N a / (\\pi k^2)`, and the start disc of the same
    area has radius :math:`\\sqrt{N a / \\pi}`.

    Examples
    --------
    >>> sigma2, radius = constant_density(1000, 70_000.0, 0.95)
    >>> round(sigma2), round(radius)
    (3718906, 4720)
    """
    k2 = -2.0 * math.log1p(-confidence)
    area = n_robots * area_per_robot_m2
    return area / (math.pi * k2), math.sqrt(area / math.pi)


@dataclass(frozen=True, eq=False)
class GaussianROI:
    """Concentration ellipse of :math:`\\mathcal{N}(\\mu, \\Sigma)` and its integration grid.

    Parameters
    ----------
    mean : array_like, shape (2,)
        :math:`\\mu`, metres.
    cov : array_like, shape (2, 2)
        :math:`\\Sigma`, symmetric positive definite, square metres.
    confidence : float
        Probability mass ``c`` of the ellipse, in (0, 1).
    cell_m : float
        Side of the square grid cells, metres (> 0).

    Attributes
    ----------
    k2 : float
        Squared Mahalanobis radius of the ellipse, :math:`\\chi^2_2(c) = -2\\ln(1 - c)`.
    points : ndarray, shape (G, 2)
        Centres of the grid cells inside the ellipse, metres (read-only).
    weights : ndarray, shape (G,)
        :math:`p(r_g)\\, a^2`, the probability mass of each cell (read-only, float64).

    Raises
    ------
    ValueError
        If ``cov`` is not symmetric positive definite, ``confidence`` is outside (0, 1),
        ``cell_m`` is not positive or longer than the ellipse's shortest semi-axis, or the grid
        would have more than ``max_cells`` cells.

    Examples
    --------
    >>> roi = GaussianROI((0.0, 0.0), ((100.0**2, 0.0), (0.0, 100.0**2)), 0.95, 5.0)
    >>> round(float(roi.weights.sum()), 2)
    0.95
    """

    mean: np.ndarray
    cov: np.ndarray
    confidence: float
    cell_m: float
    max_cells: int = MAX_CELLS
    k2: float = field(init=False)
    points: np.ndarray = field(init=False, repr=False)
    weights: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        mean = np.asarray(self.mean, dtype=float)
        cov = np.asarray(self.cov, dtype=float)
        if mean.shape != (2,) or not np.all(np.isfinite(mean)):
            raise ValueError(f"mean must be 2 finite numbers (got {self.mean!r})")
        if cov.shape != (2, 2) or not np.all(np.isfinite(cov)):
            raise ValueError(f"cov must be a finite 2 x 2 matrix (got {self.cov!r})")
        if cov[0, 1] != cov[1, 0] or cov[0, 0] <= 0 or np.linalg.det(cov) <= 0:
            raise ValueError(f"cov must be symmetric positive definite (got {cov.tolist()})")
        if not 0.0 < self.confidence < 1.0:
            raise ValueError(f"confidence must be in (0, 1) (got {self.confidence})")
        if not self.cell_m > 0:
            raise ValueError(f"cell_m must be > 0 (got {self.cell_m})")
        problem = grid_problem(cov, self.confidence, self.cell_m, self.max_cells)
        if problem is not None:
            raise ValueError(problem)
        k2 = -2.0 * np.log1p(-self.confidence)
        # Bounding box of the ellipse: half-widths k * sqrt(Sigma_ii).
        half = np.sqrt(k2 * np.diag(cov))
        n_axis = np.ceil(2.0 * half / self.cell_m).astype(int)
        # Cell centres on a grid centred on the mean (symmetric about it).
        axes = [(np.arange(n) - (n - 1) / 2.0) * self.cell_m for n in n_axis]
        gx, gy = np.meshgrid(axes[0], axes[1], indexing="xy")
        rel = np.column_stack([gx.ravel(), gy.ravel()])
        inv = np.linalg.inv(cov)
        m2 = np.einsum("gi,ij,gj->g", rel, inv, rel)
        inside = m2 <= k2
        dens = np.exp(-0.5 * m2[inside]) / (2.0 * np.pi * np.sqrt(np.linalg.det(cov)))
        object.__setattr__(self, "mean", frozen(mean, np.float64))
        object.__setattr__(self, "cov", frozen(cov, np.float64))
        object.__setattr__(self, "k2", float(k2))
        object.__setattr__(self, "points", frozen(rel[inside] + mean, np.float64))
        object.__setattr__(self, "weights", frozen(dens * self.cell_m**2, np.float64))

    @property
    def n_cells(self) -> int:
        """Number of grid cells inside the ellipse (G)."""
        return int(self.weights.size)

    @property
    def mass(self) -> float:
        """Probability mass captured by the grid, :math:`\\sum_g p(r_g) a^2` (≈ confidence)."""
        return float(self.weights.sum())

    def contains(self, xy: np.ndarray) -> np.ndarray:
        """Whether points ``xy`` (shape (..., 2), metres) lie inside the ellipse."""
        rel = np.asarray(xy, dtype=float) - self.mean
        m2 = np.einsum("...i,ij,...j->...", rel, np.linalg.inv(self.cov), rel)
        return m2 <= self.k2

    def semi_axes(self) -> tuple[np.ndarray, np.ndarray, float]:
        """Semi-axis lengths (m), their unit directions (columns) and the angle of the first
        axis (radians), for drawing."""
        vals, vecs = np.linalg.eigh(self.cov)
        lengths = np.sqrt(self.k2 * vals)
        return lengths, vecs, float(np.arctan2(vecs[1, 0], vecs[0, 0]))

    def bounding_box(self) -> tuple[float, float, float, float]:
        """``(xmin, xmax, ymin, ymax)`` of the ellipse, metres."""
        half = np.sqrt(self.k2 * np.diag(self.cov))
        return (
            float(self.mean[0] - half[0]),
            float(self.mean[0] + half[0]),
            float(self.mean[1] - half[1]),
            float(self.mean[1] + half[1]),
        )

    def expectation(self, values: np.ndarray) -> np.ndarray:
        """:math:`E[f(r) \\mid r \\in \\mathcal{R}] = \\sum_g w_g f_g / \\sum_g w_g` over the
        last axis of ``values`` (shape (..., G)).

        The sum runs in cell order (:func:`_weighted_sums`), so the coverage metric is the
        same on every CPU: a BLAS dot product accumulates in the order of the kernel that
        the CPU selects, and two machines' coverage columns differed in the last bits."""
        v = np.asarray(values, dtype=np.float64)
        flat = np.ascontiguousarray(v.reshape(-1, v.shape[-1]))
        sums = _weighted_sums(flat, np.ascontiguousarray(self.weights, dtype=np.float64))
        out = (sums / self.mass).reshape(v.shape[:-1])
        return out[()] if out.ndim == 0 else out


@njit(cache=True, nogil=True)
def _weighted_sums(values, weights):
    """``values @ weights`` for rows of ``values`` (R, G), each summed in index order with
    IEEE arithmetic (no reassociation): the same bits on any CPU."""
    out = np.empty(values.shape[0])
    for r in range(values.shape[0]):
        s = 0.0
        for g in range(weights.size):
            s += values[r, g] * weights[g]
        out[r] = s
    return out
