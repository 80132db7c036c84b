"""The animation's frames and the large-swarm drawing shortcuts."""

from __future__ import annotations

import numpy as np
import pytest

from swarmgames.config import resolve_scenario
from swarmgames.missions.coverage.plots import IMAGE_CELLS, _density_image
from swarmgames.sim import animation as anim
from swarmgames.sim.plots import link_lines
from swarmgames.sim.runner import build_mission


@pytest.mark.parametrize("n", [20, 400])
def test_blitted_frames_equal_a_full_redraw(n):
    # A frame restores the background's pixels and draws only the swarm's artists over
    # them; it must be the figure a full draw gives, pixel for pixel.
    mission = build_mission(resolve_scenario("coverage", [f"swarm.n_robots={n}"]))
    rng = np.random.default_rng(0)
    xy = [rng.uniform(-700, 700, size=(n, 2)) for _ in range(3)]
    edges = [np.sort(rng.integers(0, n, size=(2 * n, 2)), axis=1) for _ in range(3)]
    alive, radio = rng.random(n) < 0.95, rng.random(n) < 0.9
    lo, hi = anim._bounds(mission, np.stack(xy))
    drawer = anim.FrameDrawer(mission, n, lo, hi)
    moving = (*drawer.layers, drawer.clock)
    for k in range(3):
        blitted = drawer.draw(xy[k], edges[k], alive, radio, float(k)).copy()
        for artist in moving:
            artist.set_animated(False)
        drawer.canvas.draw()
        full = np.asarray(drawer.canvas.buffer_rgba())[..., :3]
        assert np.array_equal(blitted, full)
        for artist in moving:
            artist.set_animated(True)


def test_draw_frame_is_an_rgb_image():
    mission = build_mission(resolve_scenario("coverage", []))
    xy = np.array([[0.0, 0.0], [100.0, 0.0], [0.0, 100.0]])
    frame = anim.draw_frame(mission, xy, [[0, 1]], np.ones(3, bool), np.ones(3, bool), 3.0)
    assert frame.dtype == np.uint8 and frame.shape[2] == 3 and frame.std() > 0


def test_links_of_a_large_swarm_are_one_polyline_broken_by_nan():
    xy = np.arange(10.0).reshape(5, 2)
    edges = np.array([[0, 1], [1, 2], [3, 4]])
    (path,) = link_lines(xy, edges, wide=True).get_paths()
    wide = path.vertices
    assert wide.shape == (9, 2) and np.isnan(wide[2::3]).all()
    assert np.array_equal(wide[np.isfinite(wide[:, 0])].reshape(-1, 2, 2), xy[edges])
    assert len(link_lines(xy, edges, wide=False).get_paths()) == 3  # one per link


def test_the_density_image_holds_every_cell_at_its_place():
    roi = build_mission(resolve_scenario("coverage-large")).roi
    assert roi.n_cells > IMAGE_CELLS  # drawn as an image
    dens = roi.weights / roi.cell_m**2
    image, (x0, x1, y0, y1) = _density_image(roi.points, dens, roi.cell_m)
    assert np.isfinite(image).sum() == roi.n_cells
    col = np.floor((roi.points[:, 0] - x0) / roi.cell_m).astype(int)
    row = np.floor((roi.points[:, 1] - y0) / roi.cell_m).astype(int)
    assert np.array_equal(image[row, col], dens)
    assert (x1 - x0, y1 - y0) == pytest.approx(
        (image.shape[1] * roi.cell_m, image.shape[0] * roi.cell_m)
    )
