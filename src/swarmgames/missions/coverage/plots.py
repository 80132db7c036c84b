"""Drawing the coverage mission: the ROI under the robots of a paths plot or an animation."""

from __future__ import annotations

import numpy as np
from matplotlib.patches import Ellipse

__all__ = ["draw_roi"]


def draw_roi(ax, roi, cmap: str = "Greens") -> None:
    """Shade the ROI density on its grid and outline the concentration ellipse."""
    pts = roi.points
    dens = roi.weights / roi.cell_m**2
    ax.scatter(pts[:, 0], pts[:, 1], c=dens, s=2, marker="s", cmap=cmap, alpha=0.5, lw=0)
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
