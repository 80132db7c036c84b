"""Drawing the coverage mission: the ROI under the robots of a paths plot or an animation."""

from __future__ import annotations

import weakref

import numpy as np
from matplotlib.patches import Ellipse

__all__ = ["IMAGE_CELLS", "draw_roi"]

#: Above this many grid cells the density is drawn as one image instead of a marker per cell
#: (a 1 000-UAV ROI has 175 000 cells: 0.2 s per drawing as markers, a few ms as an image).
IMAGE_CELLS = 20_000


def draw_roi(ax, roi, cmap: str = "Greens") -> None:
    """Shade the ROI density on its grid and outline the concentration ellipse."""
    pts = roi.points
    dens = roi.weights / roi.cell_m**2
    if pts.shape[0] <= IMAGE_CELLS:
        ax.scatter(pts[:, 0], pts[:, 1], c=dens, s=2, marker="s", cmap=cmap, alpha=0.5, lw=0)
    else:
        if roi not in _IMAGES:  # the frames of an animation draw the same ROI
            _IMAGES[roi] = _density_image(pts, dens, roi.cell_m)
        image, extent = _IMAGES[roi]
        ax.imshow(
            image,
            origin="lower",
            extent=extent,
            cmap=cmap,
            alpha=0.5,
            interpolation="nearest",
            aspect="auto",
            zorder=0,
        )
    lengths, _, angle = roi.semi_axes()
    ax.add_patch(
        Ellipse(
            tuple(roi.mean),
            2 * lengths[0],
            2 * lengths[1],
            angle=np.degrees(angle),
            fill=False,
            ls="--",
            color="tab:green",
            label=f"ROI ({roi.confidence:.0%})",
        )
    )


_IMAGES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _density_image(pts: np.ndarray, dens: np.ndarray, cell_m: float):
    """The cells' densities as an image over their bounding box (NaN outside the ROI)
    and its ``extent``: the cells are the centres of a regular grid of step ``cell_m``."""
    lo = pts.min(axis=0)
    idx = np.rint((pts - lo) / cell_m).astype(np.int64)
    shape = idx.max(axis=0) + 1
    image = np.full((int(shape[1]), int(shape[0])), np.nan)  # NaN: not drawn
    image[idx[:, 1], idx[:, 0]] = dens
    half = cell_m / 2.0
    hi = lo + (shape - 1) * cell_m
    return image, (lo[0] - half, hi[0] + half, lo[1] - half, hi[1] + half)
