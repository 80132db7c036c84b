"""Fused compiled kernel of the windowed coverage unary (Numba).

:func:`compiled_windowed_unary` computes the same :math:`\\tilde\\phi_u` as
:func:`~swarmgames.missions.coverage.window.windowed_unary` (the module notes there give the
model), in one pass per variable instead of numpy passes over (variables × actions × cells)
arrays. For every valid variable ``k`` of every game, on one thread:

1. the weights :math:`p(r_g) a^2` of the disc of cells around ``k``'s cell (its window);
2. :math:`o_k(g)`, the best signal of the other variables within reach, as the smallest
   squared distance, then :math:`\\psi_F`;
3. for every valid action :math:`x`, :math:`\\psi_F(S_k(x), r_g)` at every cell of the window,
   the gain :math:`\\mathrm{smax}_\\tau\\{\\psi_F, o_k\\} - o_k` (the hard maximum for
   :math:`\\tau = 0`, else :math:`\\tau\\, \\mathrm{softplus}(t / \\tau)` with
   :math:`\\mathrm{softplus}(u) = \\max(u, 0) + \\log(1 + e^{-|u|})`), and its weighted sum.

No (variables × actions × cells) array is ever held, and the signals of a state's actions are
recomputed in every game that holds it (cheaper than finding the distinct states).

Arithmetic
----------
The squared distances are those of the numpy path bit for bit (differences and squares in
float64, the sum of the two axis terms in float32). The logarithm and exponential are
vectorisable float32 polynomials (Cephes ``logf`` and ``expf`` [2]_, within 1 ulp of the
correctly rounded value on their ranges here; ``log1p`` by Goldberg's correction, within
3 ulp), because the libm calls Numba emits cannot be vectorised and cost 2–9 ns each.
numpy's own float32 ``log10``, ``exp`` and ``log1p`` are within a few ulp too, so the two
paths agree to float32 rounding, not bit for bit. The weighted sum over the window is one
dot product in an order fixed by the window size. Each variable is computed by the same code
on one thread, so results are bit-identical from run to run and on any number of threads.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop (arXiv 2205.02203), eq. 5.
.. [2] S. L. Moshier, *Methods and Programs for Mathematical Functions*, Prentice Hall, 1989
   (the Cephes library: ``logf.c``, ``expf.c``).
.. [3] D. Goldberg, "What every computer scientist should know about floating-point
   arithmetic", ACM Computing Surveys 23(1), 1991, theorem 4 (``log1p``).
"""

from __future__ import annotations

import numba
import numpy as np
from llvmlite import ir
from numba import njit, prange, types
from numba.extending import intrinsic

from swarmgames.game.meanfield_compiled import POOL_LOCK
from swarmgames.missions.coverage.signal import SignalModel
from swarmgames.missions.coverage.window import RoiRaster, window_geometry

__all__ = ["compiled_windowed_unary", "exp_f32", "log1p_f32", "log_f32"]

_f32 = np.float32


@intrinsic
def _bits(typingctx, x):
    """The IEEE-754 bits of a float32 as an int32 (a bitcast, vectorisable)."""

    def codegen(context, builder, sig, args):
        return builder.bitcast(args[0], ir.IntType(32))

    return types.int32(types.float32), codegen


@intrinsic
def _from_bits(typingctx, i):
    """The float32 whose IEEE-754 bits are the int32 ``i``."""

    def codegen(context, builder, sig, args):
        return builder.bitcast(args[0], ir.FloatType())

    return types.float32(types.int32), codegen


@njit(cache=True, nogil=True, inline="always")
def log_f32(x):
    """Natural logarithm of a positive, normal float32 (Cephes ``logf``, within 1 ulp)."""
    b = _bits(x)
    e = _f32((b >> 23) & 0xFF) - _f32(126.0)
    m = _from_bits((b & np.int32(0x807FFFFF)) | np.int32(0x3F000000))  # in [0.5, 1)
    small = m < _f32(0.70710678)
    e = e - _f32(1.0) if small else e
    m = (m + m - _f32(1.0)) if small else (m - _f32(1.0))
    z = m * m
    y = _f32(7.0376836292e-2)
    y = y * m - _f32(1.1514610310e-1)
    y = y * m + _f32(1.1676998740e-1)
    y = y * m - _f32(1.2420140846e-1)
    y = y * m + _f32(1.4249322787e-1)
    y = y * m - _f32(1.6668057665e-1)
    y = y * m + _f32(2.0000714765e-1)
    y = y * m - _f32(2.4999993993e-1)
    y = y * m + _f32(3.3333331174e-1)
    y = y * m * z
    y += _f32(-2.12194440e-4) * e
    y += _f32(-0.5) * z
    return m + y + _f32(0.693359375) * e


@njit(cache=True, nogil=True, inline="always")
def exp_f32(x):
    """:math:`e^x` of a float32 in [-87, 88] (Cephes ``expf``, within 1 ulp); smaller
    arguments give :math:`e^{-87}`."""
    x = min(max(x, _f32(-87.0)), _f32(88.0))
    n = np.floor(x * _f32(1.44269504088896341) + _f32(0.5))
    r = x - n * _f32(0.693359375) - n * _f32(-2.12194440e-4)
    z = r * r
    p = _f32(1.9875691500e-4)
    p = p * r + _f32(1.3981999507e-3)
    p = p * r + _f32(8.3334519073e-3)
    p = p * r + _f32(4.1665795894e-2)
    p = p * r + _f32(1.6666665459e-1)
    p = p * r + _f32(5.0000001201e-1)
    p = p * z + r + _f32(1.0)
    return p * _from_bits((np.int32(n) + np.int32(127)) << 23)


@njit(cache=True, nogil=True, inline="always")
def log1p_f32(v):
    """:math:`\\log(1 + v)` of a float32 ``v`` in [0, 1] (Goldberg's correction of
    ``log(1 + v)`` for the rounding of ``1 + v``, within 3 ulp)."""
    u = _f32(1.0) + v
    d = u - _f32(1.0)
    return v if d == _f32(0.0) else log_f32(u) * (v / d)


_LOG10E = _f32(0.4342944819032518)


@njit(cache=True, nogil=True, fastmath={"reassoc", "nsz"})
def _dot(a, b, n):
    """Σ_i a[i] b[i] over the first n entries (vectorised; order fixed by n)."""
    s = _f32(0.0)
    for i in range(n):
        s += a[i] * b[i]
    return s


@njit(cache=True, nogil=True)
def _psi_inplace(d2, n, d02, d2f, c0, c1, scale):
    """``d2[:n]``, squared distances, replaced by ``scale`` ψ_F (one vectorised loop; one
    array, so that no runtime alias check sends it to the scalar path)."""
    for j in range(n):
        v = d2[j]
        v = v if v > d02 else d02
        v = v if v < d2f else d2f
        d2[j] = (c0 - c1 * (log_f32(v) * _LOG10E)) * scale


@njit(cache=True, nogil=True)
def _softplus_gain(f, o, n):
    """``f[:n] = softplus(f - o)`` in place, :math:`\\max(u, 0) + \\log(1 + e^{-|u|})`."""
    for j in range(n):
        u = f[j] - o[j]
        f[j] = (u if u > _f32(0.0) else _f32(0.0)) + log1p_f32(exp_f32(-abs(u)))


@njit(cache=True, nogil=True)
def _hard_gain(f, o, n):
    """``f[:n] = max(f - o, 0)`` in place."""
    for j in range(n):
        u = f[j] - o[j]
        f[j] = u if u > _f32(0.0) else _f32(0.0)


@njit(cache=True, nogil=True)
def _unary_row(
    b, k, mask, amask, states, nxt, ctr, weights, origin, cell, r, row_len, row_start,
    pair_reach2, d2f, d02, c0, c1, soft, inv_tau, tau, out,
):  # fmt: skip
    """:math:`\\tilde\\phi_u` of variable ``k`` of game ``b`` into ``out[b, k]``."""
    n_k, n_a = mask.shape[1], amask.shape[2]
    side = 2 * r + 1
    n_cells = row_start[side]
    cx, cy = ctr[b, k, 0], ctr[b, k, 1]
    w = np.empty(n_cells, np.float32)
    m = np.full(n_cells, d2f, np.float32)
    g = np.empty(n_cells, np.float32)
    ddx = np.empty(side, np.float32)
    scale = tau if soft else _f32(1.0)
    for i in range(side):
        h = row_len[i] // 2
        j0 = row_start[i]
        for t in range(row_len[i]):
            w[j0 + t] = weights[cy - r + i, cx - h + t] * scale
    # o_k as the smallest squared distance of the others within reach (numpy's arithmetic).
    sx, sy = states[b, k, 0], states[b, k, 1]
    for other in range(n_k):
        if other == k or not mask[b, other]:
            continue
        lx, ly, lz = states[b, other, 0], states[b, other, 1], states[b, other, 2]
        if (sx - lx) * (sx - lx) + (sy - ly) * (sy - ly) > pair_reach2:
            continue
        for t in range(side):
            gx = origin[0] + (cx - r + t) * cell
            ddx[t] = np.float32((gx - lx) ** 2)
        for i in range(side):
            gy = origin[1] + (cy - r + i) * cell
            ddy = np.float32((gy - ly) ** 2 + lz**2)
            h = row_len[i] // 2
            j0 = row_start[i]
            for t in range(row_len[i]):
                d2 = ddy + ddx[r - h + t]
                if d2 < m[j0 + t]:
                    m[j0 + t] = d2
    _psi_inplace(m, n_cells, d02, d2f, c0, c1, inv_tau if soft else _f32(1.0))
    for x in range(n_a):
        if not amask[b, k, x]:
            out[b, k, x] = 0.0
            continue
        px, py, pz = nxt[b, k, x, 0], nxt[b, k, x, 1], nxt[b, k, x, 2]
        for t in range(side):
            gx = origin[0] + (cx - r + t) * cell
            ddx[t] = np.float32((gx - px) ** 2)
        for i in range(side):
            gy = origin[1] + (cy - r + i) * cell
            ddy = np.float32((gy - py) ** 2 + pz**2)
            h = row_len[i] // 2
            j0 = row_start[i]
            for t in range(row_len[i]):
                g[j0 + t] = ddy + ddx[r - h + t]
        if soft:
            _psi_inplace(g, n_cells, d02, d2f, c0, c1, inv_tau)
            _softplus_gain(g, m, n_cells)
        else:
            _psi_inplace(g, n_cells, d02, d2f, c0, c1, _f32(1.0))
            _hard_gain(g, m, n_cells)
        out[b, k, x] = _dot(w, g, n_cells)


@njit(cache=True, nogil=True, parallel=True)
def _unary_rows(
    rows_b, rows_k, mask, amask, states, nxt, ctr, weights, origin, cell, r, row_len,
    row_start, pair_reach2, d2f, d02, c0, c1, soft, inv_tau, tau, out,
):  # fmt: skip
    for i in prange(rows_b.size):
        _unary_row(
            rows_b[i], rows_k[i], mask, amask, states, nxt, ctr, weights, origin, cell, r,
            row_len, row_start, pair_reach2, d2f, d02, c0, c1, soft, inv_tau, tau, out,
        )  # fmt: skip


def compiled_windowed_unary(
    raster: RoiRaster,
    signal: SignalModel,
    floor_dbm: float,
    mask: np.ndarray,
    amask: np.ndarray,
    states: np.ndarray,
    nxt: np.ndarray,
    *,
    softness_db: float = 0.0,
    workers: int = 1,
) -> np.ndarray:
    """:math:`\\tilde\\phi_u` of every game, variable and action, by the fused kernel.

    Parameters
    ----------
    raster, signal, floor_dbm, mask, amask, states, nxt, softness_db
        As :func:`~swarmgames.missions.coverage.window.windowed_unary`.
    workers : int
        Threads (at most Numba's ``NUMBA_NUM_THREADS``); the result does not depend on it.

    Returns
    -------
    ndarray of float64, shape (B, K, A); 0 at padding and invalid actions.

    Raises
    ------
    ValueError
        The raster's pad is smaller than the window radius.

    Notes
    -----
    The first call in a fresh environment compiles the kernel (about 5 s on a 2-core
    machine); later processes load it from Numba's cache.
    """
    B, K, A = amask.shape
    out = np.zeros((B, K, A))
    if B == 0 or not mask.any():
        return out
    win = window_geometry(raster, signal, floor_dbm, mask, amask, states, nxt, softness_db)
    r = win.radius
    # The disc's cells row by row (dy = -r .. r): row i holds the 2 h_i + 1 cells
    # dx = -h_i .. h_i, contiguous in the flat order of win.offsets.
    row_len = np.bincount(win.offsets[:, 0] + r, minlength=2 * r + 1).astype(np.int64)
    row_start = np.concatenate([[0], np.cumsum(row_len)]).astype(np.int64)
    rows_b, rows_k = np.nonzero(mask)
    soft = bool(win.tau > 0)
    args = (
        rows_b.astype(np.int64),
        rows_k.astype(np.int64),
        np.ascontiguousarray(mask, dtype=np.bool_),
        np.ascontiguousarray(amask, dtype=np.bool_),
        np.ascontiguousarray(states, dtype=np.float64),
        np.ascontiguousarray(nxt, dtype=np.float64),
        np.ascontiguousarray(win.ctr, dtype=np.int64),
        raster.weights,
        np.asarray(raster.origin, dtype=np.float64),
        float(win.cell),
        int(r),
        row_len,
        row_start,
        float(win.pair_reach) ** 2,
        win.d2_floor,
        win.d02,
        win.c0,
        win.c1,
        soft,
        _f32(1.0) / win.tau if soft else _f32(1.0),
        win.tau,
        out,
    )
    with POOL_LOCK:
        before = numba.get_num_threads()
        numba.set_num_threads(max(1, min(int(workers), numba.config.NUMBA_NUM_THREADS)))
        try:
            _unary_rows(*args)
        finally:
            numba.set_num_threads(before)
    return out
