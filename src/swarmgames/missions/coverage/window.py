"""The coverage unary (eq. 5) integrated only over the grid cells a UAV can change.

With a signal floor :math:`F` (``coverage.signal_floor_dbm``) every signal below it counts as
:math:`F`: :math:`\\psi_F(d) = \\max\\{\\psi_R(d), F\\}`. A UAV's signal then reaches above the
floor only within the radius :math:`d_F` where :math:`\\psi_R(d_F) = F`, i.e.
:math:`d_F = d_0\\, 10^{(T_0 - L_0 - F) / (10 n)}` (3-D; on the ground
:math:`R_F = \\sqrt{d_F^2 - z^2}`). For a variable ``k`` whose actions move it by at most
:math:`s`, every cell ``g`` farther than :math:`R_F + s` from its current position has
:math:`\\psi_F(S_k(x_k), r_g) = F` for *every* action, so the term of eq. 5 at ``g`` is the
same for all of ``k``'s actions. Such terms do not change ``k``'s marginal (mean-field
normalises each variable's distribution over its own actions, Algorithm 1) nor any deviation
gain, so they are left out, and

.. math::

    \\tilde\\phi_u(k, x_k) = \\sum_{g \\in W_k} p(r_g) a^2 \\bigl(
        \\mathrm{smax}_\\tau\\{\\psi_F(S_k(x_k), r_g),\\, o_k(g)\\} - o_k(g) \\bigr),
    \\qquad o_k(g) = \\max\\Bigl\\{F, \\max_{l \\ne k} \\psi_F(S_l, r_g)\\Bigr\\},

the expected gain of ``k``'s signal over what the other variables already give, over the
window :math:`W_k` of cells within :math:`R_F + s` of ``k`` (a disc of grid cells around
``k``'s cell). :math:`\\tilde\\phi_u = \\phi_u - c_k` with :math:`c_k = \\sum_g p(r_g) a^2
o_k(g)` free of :math:`x_k` (smax is the hard maximum for :math:`\\tau = 0`, else
:math:`\\tau \\ln(e^{a/\\tau} + e^{b/\\tau})`, for which :math:`\\mathrm{smax}\\{a, b\\} - b =
\\tau\\, \\mathrm{softplus}((a - b)/\\tau)`).

The cost per variable is the window's cell count times the actions, independent of the ROI's
size, so a stage grows linearly with the swarm at constant density. Only the other variables
within :math:`R_F + (r + 1)\\sqrt{2}\\,a` of ``k`` (``r`` the window's radius in cells) can
reach above the floor inside the window, so :math:`o_k` is a minimum of squared distances over
those pairs only (a sparse segment minimum). The signal of every distinct state's actions is
computed once per chunk of games and shared by every game in which that state appears.
Everything runs in float32 (signals are needed to 0.01 dB; float32 resolves 1e-5 dB at
-100 dBm).

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop (arXiv 2205.02203), eq. 5.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swarmgames.game.rows import shared_rows
from swarmgames.missions.coverage.roi import GaussianROI
from swarmgames.missions.coverage.signal import SignalModel

__all__ = [
    "RoiRaster",
    "WindowGeometry",
    "floor_distance_sq",
    "max_move",
    "window_geometry",
    "windowed_unary",
]


@dataclass(frozen=True, eq=False)
class RoiRaster:
    """The ROI's cell weights on the full rectangular grid of its bounding box.

    Attributes
    ----------
    origin : ndarray, shape (2,)
        Centre of cell (0, 0), metres.
    cell : float
        Cell side, metres.
    weights : ndarray of float32, shape (ny + 2 pad, nx + 2 pad)
        :math:`p(r_g) a^2` inside the ellipse, 0 outside, with ``pad`` zero cells on every side
        so that windows near the edge need no clipping.
    pad : int
    """

    origin: np.ndarray
    cell: float
    weights: np.ndarray
    pad: int

    @classmethod
    def from_roi(cls, roi: GaussianROI, pad: int) -> RoiRaster:
        """Raster of ``roi``'s points and weights with ``pad`` empty cells around it."""
        pts, a = roi.points, float(roi.cell_m)
        lo = pts.min(axis=0)
        idx = np.rint((pts - lo) / a).astype(np.int64)
        nx, ny = idx.max(axis=0) + 1
        w = np.zeros((ny + 2 * pad, nx + 2 * pad), dtype=np.float32)
        w[idx[:, 1] + pad, idx[:, 0] + pad] = roi.weights
        w.setflags(write=False)
        return cls(lo - pad * a, a, w, int(pad))


def floor_distance_sq(signal: SignalModel, floor_dbm: float) -> float:
    """:math:`d_F^2`, the squared 3-D distance at which :math:`\\psi_R` falls to the floor
    (m²); at least :math:`d_0^2`."""
    d0 = signal.reference_distance_m
    d = d0 * 10.0 ** ((signal.t0_dbm - signal.l0_db - floor_dbm) / (10.0 * signal.exponent))
    return float(max(d, d0) ** 2)


def max_move(states: np.ndarray, nxt: np.ndarray, amask: np.ndarray) -> float:
    """The longest horizontal move of a valid action, metres (0 without one):
    :math:`\\max \\lVert S_k(x)_{xy} - S_{k,xy} \\rVert` over ``amask`` (B, K, A), for
    ``states`` (B, K, 3) and ``nxt`` (B, K, A, 3). The square root of the largest squared
    move, which is the largest of the moves' norms bit for bit."""
    dx = nxt[..., 0] - states[:, :, None, 0]
    dy = nxt[..., 1] - states[:, :, None, 1]
    return float(np.sqrt(np.max(dx * dx + dy * dy, where=amask, initial=0.0)))


def _disc_offsets(rho: float) -> tuple[np.ndarray, np.ndarray]:
    """Cell offsets (dy, dx) of the disc of radius ``rho`` cells, and their flat index into
    the (2r + 1)² square, ``r = ceil(rho)``."""
    r = int(np.ceil(rho))
    j = np.arange(-r, r + 1)
    dy, dx = np.meshgrid(j, j, indexing="ij")
    keep = (dx**2 + dy**2 <= rho**2).ravel()
    flat = np.flatnonzero(keep)
    return np.column_stack([dy.ravel()[keep], dx.ravel()[keep]]), flat


@dataclass(frozen=True, eq=False)
class WindowGeometry:
    """The windows of one batch of local games and the constants of :math:`\\psi_F` in
    float32, shared by the numpy and the compiled integration.

    Attributes
    ----------
    cell : float
        Cell side ``a``, metres.
    radius : int
        Window radius in cells, ``r = ceil(rho)``.
    offsets : ndarray of int64, shape (C, 2)
        Cell offsets (dy, dx) of the window's disc, row-major.
    flat : ndarray of int64, shape (C,)
        Their flat index into the (2r + 1)² square.
    n_cells : int
        C.
    ctr : ndarray of int64, shape (B, K, 2)
        Raster cell (x, y) of each variable's window centre (clipped so that the window stays
        inside the padded raster).
    pair_reach : float
        Horizontal distance beyond which another variable cannot change :math:`o_k` inside
        the window, :math:`2 R_F + s + a`, metres.
    d2_floor, d02, c0, c1 : numpy.float32
        :math:`d_F^2`, :math:`d_0^2` and :math:`\\psi = c_0 - c_1 \\log_{10} d^2`.
    tau : numpy.float32
        τ of the smooth maximum.
    fast_softplus : bool
        Whether :math:`e^{t / \\tau}` stays finite for every gain ``t`` of the batch.
    """

    cell: float
    radius: int
    offsets: np.ndarray
    flat: np.ndarray
    n_cells: int
    ctr: np.ndarray
    pair_reach: float
    d2_floor: np.float32
    d02: np.float32
    c0: np.float32
    c1: np.float32
    tau: np.float32
    fast_softplus: bool


def window_geometry(
    raster: RoiRaster,
    signal: SignalModel,
    floor_dbm: float,
    mask: np.ndarray,
    amask: np.ndarray,
    states: np.ndarray,
    nxt: np.ndarray,
    softness_db: float = 0.0,
) -> WindowGeometry:
    """The :class:`WindowGeometry` of a batch (arguments as :func:`windowed_unary`; at least
    one valid variable).

    Raises
    ------
    ValueError
        The raster's pad is smaller than the window radius.
    """
    a = raster.cell
    d2f = floor_distance_sq(signal, floor_dbm)
    z2 = np.where(mask, states[..., 2], 0.0) ** 2
    reach_h = float(np.sqrt(max(d2f - float(z2.min(initial=np.inf)), 0.0)))
    s_max = max_move(states, nxt, amask)
    # A cell's centre is within a/sqrt(2) of the cell holding the UAV: every cell an action
    # reaches above the floor lies within rho cells of the window's centre cell.
    rho = (reach_h + s_max) / a + np.sqrt(0.5)
    r = int(np.ceil(rho))
    if r > raster.pad:
        raise ValueError(f"raster pad must be >= the window radius {r} cells (got {raster.pad})")
    offs, flat = _disc_offsets(rho)
    # Window of each variable: the disc of cells around its current cell.
    ctr = np.rint((states[..., :2] - raster.origin) / a).astype(np.int64)  # (B, K, 2) x, y
    ctr = np.where(mask[..., None], ctr, raster.pad)
    ny, nx = raster.weights.shape
    ctr[..., 0] = np.clip(ctr[..., 0], r, nx - 1 - r)
    ctr[..., 1] = np.clip(ctr[..., 1], r, ny - 1 - r)
    # ψ = (T0 - L0) - 5 n log10(d² / d0²) = c0 - c1 log10(d²)
    f32 = np.float32
    c1 = f32(5.0 * signal.exponent)
    d02 = f32(signal.reference_distance_m**2)
    c0 = f32(signal.t0_dbm - signal.l0_db) + c1 * np.log10(d02)
    # t = ψ_F(next) - o_k <= ψ_R(lowest altitude) - F: exp(t / τ) stays finite below 80.
    psi_top = float(signal.power(np.sqrt(max(float(z2.min(initial=np.inf)), 0.0))))
    fast = softness_db > 0 and (psi_top - floor_dbm) / softness_db < 80.0
    return WindowGeometry(
        cell=a,
        radius=r,
        offsets=offs,
        flat=flat,
        n_cells=int(flat.size),
        ctr=ctr,
        # Another variable changes o_k only where it reaches above the floor: within R_F of
        # it. Cells of the window beyond every action's reach hold the floor for all of k's
        # actions (a term free of x_k whatever o_k is), so o_k is needed only within R_F + s.
        pair_reach=2.0 * reach_h + s_max + a,
        d2_floor=f32(d2f),
        d02=d02,
        c0=c0,
        c1=c1,
        tau=f32(softness_db),
        fast_softplus=bool(fast),
    )


def _morton(ix: np.ndarray, iy: np.ndarray) -> np.ndarray:
    """Z-order (Morton) code of non-negative cell indices < 2**21: nearby cells, nearby codes."""

    def spread(v):
        v = v.astype(np.uint64) & np.uint64(0x1FFFFF)
        for shift, mask in (
            (32, 0x1F00000000FFFF),
            (16, 0x1F0000FF0000FF),
            (8, 0x100F00F00F00F00F),
            (4, 0x10C30C30C30C30C3),
            (2, 0x1249249249249249),
        ):
            v = (v | (v << np.uint64(shift))) & np.uint64(mask)
        return v

    return spread(ix) | (spread(iy) << np.uint64(1))


def windowed_unary(
    raster: RoiRaster,
    signal: SignalModel,
    floor_dbm: float,
    mask: np.ndarray,
    amask: np.ndarray,
    states: np.ndarray,
    nxt: np.ndarray,
    *,
    softness_db: float = 0.0,
    chunk_elems: int = 2_000_000,
    workers: int = 1,
    state_ids: np.ndarray | None = None,
) -> np.ndarray:
    """:math:`\\tilde\\phi_u` of every game, variable and action (module notes), (B, K, A).

    Parameters
    ----------
    raster : RoiRaster
        Built with ``pad`` >= the window radius in cells (checked).
    signal : SignalModel
    floor_dbm : float
    mask : (B, K) bool
    amask : (B, K, A) bool
        Valid actions (false on padding).
    states : (B, K, 3)
        Current (or virtual) positions, metres.
    nxt : (B, K, A, 3)
        Positions after each action, metres.
    softness_db : float
        τ of the smooth maximum (0 = hard maximum).
    chunk_elems : int
        Upper bound on the elements of one (games, K, A, cells) block.
    state_ids : (B, K) int, optional
        Hints of equal states across games (for example ``2 * member + is_virtual``); rows
        with equal ids share their action signals where their states and next states are
        equal too (:func:`~swarmgames.game.rows.shared_rows`); default:
        compared by value.
    workers : int
        Threads over chunks of games (numpy releases the GIL; the result does not depend on
        it).

    Returns
    -------
    ndarray of float64, shape (B, K, A); 0 at padding and invalid actions.
    """
    B, K, A = amask.shape
    out = np.zeros((B, K, A))
    if B == 0 or not mask.any():
        return out
    win = window_geometry(raster, signal, floor_dbm, mask, amask, states, nxt, softness_db)
    a, r, offs, flat, C, ctr = win.cell, win.radius, win.offsets, win.flat, win.n_cells, win.ctr
    side, nx, pair_reach = 2 * r + 1, raster.weights.shape[1], win.pair_reach
    f32 = np.float32
    d2f32, tau, c1, d02, c0 = win.d2_floor, win.tau, win.c1, win.d02, win.c0

    def psi(d2):
        # ψ_F from squared distances, in place: floor above d_F, clamp below d0.
        np.clip(d2, d02, d2f32, out=d2)
        np.log10(d2, out=d2)
        d2 *= -c1
        d2 += c0
        return d2

    step = max(1, chunk_elems // max(1, K * A * C))
    fast_softplus = win.fast_softplus
    # Games in spatial order (by the cell of their first variable): the games of a chunk
    # share most of their members, whose action signals are then computed once.
    order = np.argsort(_morton(ctr[:, 0, 0], ctr[:, 0, 1]), kind="stable")
    jr = np.arange(-r, r + 1)

    def chunk(lo: int) -> None:
        hi = min(B, lo + step)
        sl = order[lo:hi]
        m = mask[sl]
        b = hi - lo
        st = states[sl]
        cx = ctr[sl, :, 0]
        cy = ctr[sl, :, 1]
        # Cell centres of each variable's window, relative coordinates per axis (b, K, side).
        gx = raster.origin[0] + (cx[..., None] + jr) * a
        gy = raster.origin[1] + (cy[..., None] + jr) * a

        # o_k: the best other signal, as the smallest squared distance of a relevant other.
        gb, gk, gl = np.nonzero(m[:, :, None] & m[:, None, :] & ~np.eye(K, dtype=bool))
        dxy = st[gb, gk, :2] - st[gb, gl, :2]
        near = np.einsum("ij,ij->i", dxy, dxy) <= pair_reach**2
        gb, gk, gl = gb[near], gk[near], gl[near]
        o2 = np.full((b * K, C), d2f32, dtype=f32)
        if gb.size:
            # Segment minimum over each variable's others. Variables are ordered by their
            # number of others (descending) and pairs by (rank within the variable, that
            # order): the pairs of rank j then form a contiguous block whose variables are the
            # first n_j, so each rank is one in-place minimum over a prefix.
            seg = gb * K + gk  # sorted (np.nonzero is row-major)
            starts = np.flatnonzero(np.r_[True, seg[1:] != seg[:-1]])
            counts = np.diff(np.r_[starts, seg.size])
            rank = np.arange(seg.size) - np.repeat(starts, counts)
            by_count = np.argsort(-counts, kind="stable")
            pos = np.empty(starts.size, dtype=np.int64)
            pos[by_count] = np.arange(starts.size)
            order_p = np.lexsort((np.repeat(pos, counts), rank))
            gb, gk, gl = gb[order_p], gk[order_p], gl[order_p]
            ddx = ((gx[gb, gk] - st[gb, gl, 0, None]) ** 2).astype(f32)  # (P, side)
            ddy = ((gy[gb, gk] - st[gb, gl, 1, None]) ** 2 + st[gb, gl, 2, None] ** 2).astype(f32)
            n_rank = np.bincount(rank)
            best = np.full((starts.size, side * side), d2f32, dtype=f32)
            scratch = np.empty((int(n_rank[0]), side, side), dtype=f32)
            off = 0
            for n_j in n_rank:
                n_j = int(n_j)
                blk = scratch[:n_j]
                np.add(ddy[off : off + n_j, :, None], ddx[off : off + n_j, None, :], out=blk)
                np.minimum(best[:n_j], blk.reshape(n_j, -1), out=best[:n_j])
                off += n_j
            o2[seg[starts][by_count]] = best[:, flat]
        o2 = o2.reshape(b, K, C)
        o = psi(o2)

        # Signal of every action of every distinct state over its window, shared by games.
        rows = np.flatnonzero(m.ravel())
        vx, vy = cx.reshape(-1)[rows], cy.reshape(-1)[rows]
        w_rows = raster.weights.ravel()[
            (vy[:, None] + offs[:, 0]) * nx + (vx[:, None] + offs[:, 1])
        ]
        if state_ids is not None:
            key, _ = shared_rows(
                state_ids[sl].reshape(-1)[rows],
                st.reshape(b * K, 3)[rows],
                nxt[sl].reshape(b * K, A * 3)[rows],
            )
        else:
            key = np.concatenate(
                [st.reshape(b * K, 3)[rows], nxt[sl].reshape(b * K, A * 3)[rows]], axis=1
            )
        _, first, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
        inv = inv.reshape(-1)
        src = rows[first]
        ub, uk = np.divmod(src, K)
        nx_u = nxt[sl][ub, uk]  # (U, A, 3)
        ddx = ((gx[ub, uk][:, None, :] - nx_u[..., 0, None]) ** 2).astype(f32)  # (U, A, side)
        ddy = (gy[ub, uk][:, None, :] - nx_u[..., 1, None]) ** 2 + nx_u[..., 2, None] ** 2
        d2 = (ddy.astype(f32)[..., :, None] + ddx[..., None, :]).reshape(-1, A, side * side)
        f = psi(np.ascontiguousarray(d2[..., flat]))  # (U, A, C)

        # Gain over the others' best, weighted and summed over the window.
        o_rows = o.reshape(b * K, C)[rows]
        if tau > 0 and fast_softplus:
            # τ log1p(exp(t / τ)), safe from overflow since t / τ < 80 (checked above); the
            # 1/τ and τ scalings go to the smaller arrays f, o and w.
            f *= 1 / tau
            o_rows *= 1 / tau
            w_rows *= tau
            t = f[inv]  # (V, A, C) for the valid variables V
            t -= o_rows[:, None, :]
            np.exp(t, out=t)
            np.log1p(t, out=t)
            val = np.matmul(t, w_rows[:, :, None])[..., 0]  # (V, A)
            blk = np.zeros((b * K, A))
            blk[rows] = val
            out[sl] = blk.reshape(b, K, A)
            return
        t = f[inv]
        t -= o_rows[:, None, :]
        if tau > 0:
            # τ softplus(t / τ) = max(t, 0) + τ log1p(exp(-|t| / τ))
            u = np.abs(t)
            u *= -1 / tau
            np.exp(u, out=u)
            np.log1p(u, out=u)
            u *= tau
            np.maximum(t, f32(0), out=t)
            t += u
        else:
            np.maximum(t, f32(0), out=t)
        val = np.matmul(t, w_rows[:, :, None])[..., 0]  # (V, A)
        blk = np.zeros((b * K, A))
        blk[rows] = val
        out[sl] = blk.reshape(b, K, A)

    starts_all = range(0, B, step)
    if workers > 1 and len(starts_all) > 1:
        # numpy releases the GIL in its loops: chunks write disjoint rows of ``out``.
        from concurrent.futures import ThreadPoolExecutor

        with ThreadPoolExecutor(workers) as pool:
            list(pool.map(chunk, starts_all))
    else:
        for lo in starts_all:
            chunk(lo)
    out[~amask] = 0.0
    return out
