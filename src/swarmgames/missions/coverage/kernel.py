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

No (variables × actions × cells) array is ever held. The signals of step 3 depend on the
state alone: they are computed once for every distinct state (equal id, state, next states
and valid actions: :func:`~swarmgames.game.rows.shared_rows`) of a chunk of
games in spatial order, into a table of states (:func:`_state_table`) that the variables'
gains read (:func:`_gain_rows`); with a
:class:`~swarmgames.game.kept.KeptRows`, that table is kept across calls,
and a state already there is not computed again.

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

from dataclasses import dataclass, replace
from functools import cached_property
from typing import ClassVar

import numpy as np
from llvmlite import ir
from numba import njit, prange, types
from numba.extending import intrinsic

from swarmgames.game.capabilities import PairSourceCapabilities
from swarmgames.game.equal import EqualGames, equal_games
from swarmgames.game.kept import KeptRows
from swarmgames.game.meanfield_compiled import PARALLEL_MIN_GAMES, in_parallel, pool
from swarmgames.game.rows import shared_rows
from swarmgames.missions.coverage.signal import SignalModel
from swarmgames.missions.coverage.window import (
    RoiRaster,
    _morton,
    window_geometry,
    windowed_unary,
)

__all__ = ["CoveragePairs", "compiled_windowed_unary", "exp_f32", "log1p_f32", "log_f32"]

_f32 = np.float32

#: Ids at or above this (or negative) are not kept across calls (:class:`KeptRows`).
_MAX_KEPT_ID = 1 << 26

PARALLEL_MIN_ROWS = 16 * PARALLEL_MIN_GAMES
"""Variables (of all the games of a call) from which the unary runs on the thread pool;
fewer (a few games, one UAV deciding alone) run on the calling thread
(:func:`~swarmgames.game.meanfield_compiled.pool`)."""


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
    """:math:`\\log(1 + v)` of a finite float32 ``v`` >= 0 (Goldberg's correction of
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
def _psi_inplace(d2, n, d02, d2f, c0, c1):
    """``d2[:n]``, squared distances, replaced by ψ_F (one vectorised loop over one array,
    so that no runtime alias check sends it to the scalar path)."""
    for j in range(n):
        v = d2[j]
        v = v if v > d02 else d02
        v = v if v < d2f else d2f
        d2[j] = c0 - c1 * (log_f32(v) * _LOG10E)


@njit(cache=True, nogil=True, inline="always")
def _axis_d2(p, origin, c, r, cell, extra, out):
    """One axis's squared distances from coordinate ``p`` to the 2 r + 1 cell centres of the
    window's square around cell ``c``, plus ``extra`` (float64, then float32: numpy's
    arithmetic), into ``out``."""
    for t in range(2 * r + 1):
        g = origin + (c - r + t) * cell
        out[t] = np.float32((g - p) ** 2 + extra)


@njit(cache=True, nogil=True)
def _disc_d2(ddy, ddx, jy, jx, out, n):
    """``out[:n]``: the squared distances at the disc's cells, ``ddy[jy] + ddx[jx]`` (the
    sum in float32)."""
    for j in range(n):
        out[j] = ddy[jy[j]] + ddx[jx[j]]


@njit(cache=True, nogil=True, inline="always")
def _square_d2(px, py, pz, cx, cy, origin, cell, r, width, d2f, ddx, ddy, sq):
    """The running minimum of ``sq`` with the squared distances from (px, py, pz) to the
    cells of the window's square around cell (cx, cy), ``sq[y * width + t]`` (the
    arithmetic of :func:`_disc_d2`). Rows are padded to ``width`` (whole vectors, no scalar
    remainder; ``ddx``'s pad holds d_F²). ``sq`` holds at most ``d2f``, so a row whose
    ``ddy`` reaches it is left as it is."""
    _axis_d2(px, origin[0], cx, r, cell, 0.0, ddx)
    _axis_d2(py, origin[1], cy, r, cell, pz**2, ddy)
    for y in range(2 * r + 1):
        if ddy[y] >= d2f:
            continue
        base = y * width
        for t in range(width):
            v = ddy[y] + ddx[t]
            sq[base + t] = v if v < sq[base + t] else sq[base + t]


@njit(cache=True, nogil=True)
def _gather(src, idx, scale, out, n):
    """``out[:n] = src[idx[:n]] * scale``."""
    for j in range(n):
        out[j] = src[idx[j]] * scale


@njit(cache=True, nogil=True, parallel=True)
def _state_table(
    src_b, src_k, dest, amask, nxt, ctr, origin, cell, r, jy, jx, d02, d2f, c0, c1, soft,
    inv_tau, table,
):  # fmt: skip
    """Signal of every action of every distinct state (game ``src_b``, variable ``src_k``)
    over its window, into row ``dest`` of ``table`` (rows, A, C):
    :math:`e^{(\\psi_F - F) / \\tau}` with the smooth maximum, else :math:`\\psi_F`. The disc's
    cell ``j`` is at row ``jy[j]`` and column ``jx[j]`` of the window's square."""
    n_a = amask.shape[2]
    side = 2 * r + 1
    n_cells = jy.size
    floor = c0 - c1 * (log_f32(d2f) * _LOG10E)
    for u in prange(src_b.size):
        b, k = src_b[u], src_k[u]
        ddx = np.empty(side, np.float32)
        ddy = np.empty(side, np.float32)
        for x in range(n_a):
            if not amask[b, k, x]:
                continue
            row = table[dest[u], x]
            _axis_d2(nxt[b, k, x, 0], origin[0], ctr[b, k, 0], r, cell, 0.0, ddx)
            _axis_d2(nxt[b, k, x, 1], origin[1], ctr[b, k, 1], r, cell, nxt[b, k, x, 2] ** 2, ddy)
            _disc_d2(ddy, ddx, jy, jx, row, n_cells)
            _psi_inplace(row, n_cells, d02, d2f, c0, c1)
            if soft:
                _exp_excess(row, n_cells, floor, inv_tau)


@njit(cache=True, nogil=True)
def _exp_excess(v, n, floor, inv_tau):
    """``v[:n]`` replaced by :math:`e^{(v - F) / \\tau}` in place."""
    for j in range(n):
        v[j] = exp_f32((v[j] - floor) * inv_tau)


@njit(cache=True, nogil=True)
def _softplus_gain(e, inv_eo, g, n):
    """``g[:n] = log(1 + e inv_eo)``: :math:`\\mathrm{softplus}((f - o) / \\tau)` from
    :math:`e^{(f - F)/\\tau}` and :math:`e^{-(o - F)/\\tau}`."""
    for j in range(n):
        g[j] = log1p_f32(e[j] * inv_eo[j])


@njit(cache=True, nogil=True)
def _hard_gain(f, o, g, n):
    """``g[:n] = max(f - o, 0)``."""
    for j in range(n):
        u = f[j] - o[j]
        g[j] = u if u > _f32(0.0) else _f32(0.0)


@njit(cache=True, nogil=True, parallel=True)
def _gain_rows(
    rows_b, rows_k, rows_u, mask, amask, states, ctr, weights, origin, cell, r, in_raster,
    in_square, pair_reach2, d02, d2f, c0, c1, soft, inv_tau, tau, table, out,
):  # fmt: skip
    """:math:`\\tilde\\phi_u` of every valid variable (row) into ``out``, its actions'
    signals taken from row ``rows_u`` of ``table``. The disc's cell ``j`` is entry
    ``in_raster[j]`` of the raster's flat ``weights`` from the window's corner, and entry
    ``in_square[j]`` of the window's padded square."""
    n_k, n_a = mask.shape[1], amask.shape[2]
    n_x = weights.shape[1]
    flat_w = weights.reshape(weights.size)
    side = 2 * r + 1
    n_cells = in_square.size
    floor = c0 - c1 * (log_f32(d2f) * _LOG10E)
    scale = tau if soft else _f32(1.0)
    width = (side + 15) // 16 * 16
    for i in prange(rows_b.size):
        b, k, u = rows_b[i], rows_k[i], rows_u[i]
        cx, cy = ctr[b, k, 0], ctr[b, k, 1]
        w = np.empty(n_cells, np.float32)
        m = np.empty(n_cells, np.float32)
        g = np.empty(n_cells, np.float32)
        sq = np.full(side * width, d2f, np.float32)
        ddx = np.full(width, d2f, np.float32)
        ddy = np.empty(side, np.float32)
        _gather(flat_w[(cy - r) * n_x + cx - r :], in_raster, scale, w, n_cells)
        # o_k as the smallest squared distance of the others within reach, on the window's
        # padded square, then read on the disc.
        sx, sy = states[b, k, 0], states[b, k, 1]
        for other in range(n_k):
            if other == k or not mask[b, other]:
                continue
            lx, ly, lz = states[b, other, 0], states[b, other, 1], states[b, other, 2]
            if (sx - lx) * (sx - lx) + (sy - ly) * (sy - ly) > pair_reach2:
                continue
            _square_d2(lx, ly, lz, cx, cy, origin, cell, r, width, d2f, ddx, ddy, sq)
        _gather(sq, in_square, _f32(1.0), m, n_cells)
        _psi_inplace(m, n_cells, d02, d2f, c0, c1)
        if soft:
            _exp_excess(m, n_cells, floor, -inv_tau)
        for x in range(n_a):
            if not amask[b, k, x]:
                out[b, k, x] = 0.0
                continue
            if soft:
                _softplus_gain(table[u, x], m, g, n_cells)
            else:
                _hard_gain(table[u, x], m, g, n_cells)
            out[b, k, x] = _dot(w, g, n_cells)


@njit(cache=True, nogil=True)
def _state_chunks(row_game, slot, n_slots, cap):
    """Rows (grouped by game, in the order to compute them) split into chunks of whole
    games, each holding at most ``cap`` distinct slots (``cap`` >= a game's rows).

    Returns ``(row_start, local, src, src_start)``: chunk ``c`` is rows
    ``row_start[c]:row_start[c + 1]``; ``local`` is every row's slot in its chunk's table,
    whose entry ``j`` is defined by row ``src[src_start[c] + j]``."""
    n = row_game.size
    chunk = np.full(n_slots, -1, np.int64)  # the chunk in which a slot was last placed
    seen = np.full(n_slots, -1, np.int64)  # the row of the game that counted it
    where = np.empty(n_slots, np.int64)
    local = np.empty(n, np.int64)
    src = np.empty(n, np.int64)
    row_start = [0]
    src_start = [0]
    c, used, n_src = 0, 0, 0
    i = 0
    while i < n:
        j = i
        while j < n and row_game[j] == row_game[i]:
            j += 1
        new = 0
        for t in range(i, j):
            u = slot[t]
            if chunk[u] != c and seen[u] != i:
                seen[u] = i
                new += 1
        if used > 0 and used + new > cap:
            row_start.append(i)
            src_start.append(n_src)
            c += 1
            used = 0
        for t in range(i, j):
            u = slot[t]
            if chunk[u] != c:
                chunk[u] = c
                where[u] = used
                src[n_src] = t
                n_src += 1
                used += 1
            local[t] = where[u]
        i = j
    row_start.append(n)
    src_start.append(n_src)
    return np.array(row_start), local, src[:n_src], np.array(src_start)


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
    state_ids: np.ndarray | None = None,
    chunk_elems: int = 2_000_000,
    rows: np.ndarray | None = None,
    signals: KeptRows | None = None,
    row_index: np.ndarray | None = None,
) -> np.ndarray:
    """:math:`\\tilde\\phi_u` of every game, variable and action, by the fused kernel.

    Parameters
    ----------
    raster, signal, floor_dbm, mask, amask, states, nxt, softness_db
        As :func:`~swarmgames.missions.coverage.window.windowed_unary`.
    workers : int
        Threads (at most Numba's ``NUMBA_NUM_THREADS``); the result does not depend on it.
    state_ids : (B, K) int, optional
        Hints of equal states across games (for example ``2 * member + is_virtual``); rows
        with equal ids share their actions' signals only where their states, next states
        and valid actions are equal too. Default: every row its own.
    chunk_elems : int
        Upper bound on the elements of the table of distinct states' action signals of one
        chunk of games (float32).
    rows : (B, K) bool, optional
        Compute only these variables (the others are 0); every variable of ``mask`` still
        counts among the others of its game, and a computed variable's values are those of
        the whole computation, bit for bit. Default: every valid variable.
    signals : KeptRows, optional
        A table of action signals kept across calls (with ``state_ids``): a state found
        there with the same values and window is not computed again
        (:mod:`~swarmgames.game.kept`). The result is the same bit for bit.
    row_index : (B, K) int, optional
        The stage row of every variable (``LocalGameBatch.rows``): variables of equal rows
        hold equal states, next states and valid actions, so their actions' signals are
        computed once from the index alone. Default: found by comparing those values
        (:func:`~swarmgames.game.rows.shared_rows`). The result is the same bit for bit.

    Returns
    -------
    ndarray of float64, shape (B, K, A); 0 at padding and invalid actions.

    Raises
    ------
    ValueError
        The raster's pad is smaller than the window radius.

    Notes
    -----
    The smooth maximum is computed as :math:`\\log(1 + e^{(f - F)/\\tau}
    e^{-(o - F)/\\tau})`, whose factors are finite when :math:`(\\psi_{top} - F) / \\tau
    < 80`; a batch with a smaller τ (``WindowGeometry.fast_softplus`` false) goes to the
    numpy path. The first call in a fresh environment compiles the kernels (about 10 s on a
    2-core machine, reported by ``swarmgames bench``); later processes load them from
    Numba's cache.
    """
    B, K, A = amask.shape
    out = np.zeros((B, K, A))
    if B == 0 or not mask.any():
        return out
    win = window_geometry(raster, signal, floor_dbm, mask, amask, states, nxt, softness_db)
    soft = bool(win.tau > 0)
    if soft and not win.fast_softplus:
        return windowed_unary(
            raster, signal, floor_dbm, mask, amask, states, nxt, softness_db=softness_db
        )
    r, n_cells = win.radius, win.n_cells
    # The disc's cells (dy, dx) as rows and columns of the window's (2r + 1)² square.
    jy = np.ascontiguousarray(win.offsets[:, 0] + r, dtype=np.int64)
    jx = np.ascontiguousarray(win.offsets[:, 1] + r, dtype=np.int64)
    in_raster = jy * raster.weights.shape[1] + jx
    in_square = jy * ((2 * r + 1 + 15) // 16 * 16) + jx
    mask = np.ascontiguousarray(mask, dtype=np.bool_)
    amask = np.ascontiguousarray(amask, dtype=np.bool_)
    states = np.ascontiguousarray(states, dtype=np.float64)
    nxt = np.ascontiguousarray(nxt, dtype=np.float64)
    ctr = np.ascontiguousarray(win.ctr, dtype=np.int64)
    origin = np.asarray(raster.origin, dtype=np.float64)
    ids = np.arange(B * K).reshape(B, K) if state_ids is None else np.asarray(state_ids)
    inv_tau = _f32(1.0) / win.tau if soft else _f32(1.0)
    consts = (win.d02, win.d2_floor, win.c0, win.c1, soft, inv_tau)
    geom = (origin, float(win.cell), int(r))
    # Rows grouped by game, the games in spatial order (by the cell of their first variable),
    # in chunks of games whose distinct states fill at most cap rows of one table: the games
    # of a chunk share most members, and a state is computed once a chunk.
    order = np.argsort(_morton(ctr[:, 0, 0], ctr[:, 0, 1]), kind="stable")
    sub = mask[order] if rows is None else mask[order] & rows[order]
    pos, rk = np.nonzero(sub)
    rb = order[pos]
    row_ids = ids[rb, rk].astype(np.int64)
    if row_index is None:
        slot, first = shared_rows(row_ids, states[rb, rk], nxt[rb, rk], amask[rb, rk])
    else:
        _, first, slot = np.unique(
            np.asarray(row_index)[rb, rk], return_index=True, return_inverse=True
        )
        slot = slot.reshape(-1)
    # The kept table of signals needs small non-negative ids (a direct-address index).
    keep = signals is not None and state_ids is not None and rb.size > 0
    keep = keep and row_ids.min() >= 0 and row_ids.max() < _MAX_KEPT_ID
    cap = max(K, chunk_elems // max(1, A * n_cells))
    if keep:  # chunks of up to half the kept table: fewer, larger kernel launches
        cap = max(cap, signals.capacity(A, n_cells, int(row_ids.max()) + 1) // 2)
    row_start, local, src, src_start = _state_chunks(pos, slot, first.size, cap)
    most = int(np.diff(src_start).max())
    if keep:
        def_ids = row_ids[src]
        # The values that an entry of the kept table must match, and the window's geometry.
        dr, dk = rb[src], rk[src]
        keys = np.concatenate([states[dr, dk], nxt[dr, dk].reshape(src.size, -1), amask[dr, dk]],
                              axis=1)  # fmt: skip
        consts_key = tuple(float(v) for v in (win.d02, win.d2_floor, win.c0, win.c1, inv_tau))
        geometry = (r, n_cells, A, soft, *consts_key, *origin.tolist(), float(win.cell),
                    raster.weights.shape)  # fmt: skip
        signals.prepare(geometry, A, n_cells, most, int(def_ids.max()) + 1, keys.shape[1])
        buf = signals.table
    else:
        # One table for every chunk: fresh pages would be faulted in and zeroed by the
        # system at every chunk.
        buf = np.empty((most, A, n_cells), dtype=np.float32)
    with pool(rb.size >= PARALLEL_MIN_ROWS, int(workers)):
        for c in range(row_start.size - 1):
            lo, hi = row_start[c], row_start[c + 1]
            part = slice(src_start[c], src_start[c + 1])
            defs = src[part]
            if keep:
                at, todo = signals.assign(def_ids[part], keys[part])
                defs = defs[todo]
                dest = at[todo]
            else:
                at = dest = np.arange(defs.size)
            if defs.size:
                _state_table(rb[defs], rk[defs], dest, amask, nxt, ctr, *geom, jy, jx,
                             *consts, buf)  # fmt: skip
            _gain_rows(rb[lo:hi], rk[lo:hi], at[local[lo:hi]], mask, amask, states, ctr,
                       raster.weights, *geom, in_raster, in_square,
                       float(win.pair_reach) ** 2, *consts, win.tau, buf, out)  # fmt: skip
    return out


@njit(cache=True, nogil=True)
def _pair_row(px, py, pz, i, valid, n, scale, offset, d02, inv_sep, crowd, weight, row):
    """``row[:n]``: W between point ``i`` and every point ``m`` of a game,
    :math:`\\alpha_b (2 \\psi_R(d) - c\\, \\max(0, 1 - d / d_{sep})^2)` times ``valid[m]``
    (d² in float64 as pair_table's, then float32: the logarithm, and the penalty from
    the float32 square root).

    Two loops: the squared distances (float64 lanes), then the rest in float32 lanes, twice
    as wide. Without crowding (``crowd`` = +0) the penalty term is +0 whatever the distance,
    and subtracting it changes nothing, so it is left out."""
    xi, yi, zi = px[i], py[i], pz[i]
    for m in range(n):
        dx = xi - px[m]
        dy = yi - py[m]
        dz = zi - pz[m]
        row[m] = np.float32(dx * dx + dy * dy + dz * dz)
    if crowd == _f32(0.0):
        for m in range(n):
            v = row[m]
            v = v if v > d02 else d02
            row[m] = ((log_f32(v) * _LOG10E) * scale + offset) * weight * valid[m]
        return
    for m in range(n):
        v = row[m]
        pen = _f32(1.0) - np.sqrt(v) * inv_sep
        pen = pen if pen > _f32(0.0) else _f32(0.0)
        v = v if v > d02 else d02
        val = (log_f32(v) * _LOG10E) * scale + offset
        row[m] = (val - crowd * (pen * pen)) * weight * valid[m]


@njit(cache=True, nogil=True)
def _game_points(points, valid, b):
    """Game ``b``'s next positions as flat (K A,) coordinate arrays, its validity as float32,
    and ``used``, one past the last valid point: the columns after it are 0, so padding
    costs no arithmetic."""
    n = valid.shape[1] * valid.shape[2]
    px = np.ascontiguousarray(points[b, :, :, 0]).reshape(n)
    py = np.ascontiguousarray(points[b, :, :, 1]).reshape(n)
    pz = np.ascontiguousarray(points[b, :, :, 2]).reshape(n)
    vm = valid[b].reshape(n).astype(np.float32)
    used = 0
    for i in range(n):
        if vm[i] != 0.0:
            used = i + 1
    return px, py, pz, vm, used


@njit(cache=True, nogil=True, parallel=True)
def _pair_tables(games, points, valid, scale, offset, d02, inv_sep, crowd, weight, out):
    """W of ``games`` into ``out`` (G, K, A, K, A); ``weight`` is every game's weight (B,)."""
    n_k, n_a = valid.shape[1], valid.shape[2]
    n = n_k * n_a
    for g in prange(games.size):
        b = games[g]
        px, py, pz, vm, used = _game_points(points, valid, b)
        w = out[g].reshape((n, n))
        for i in range(n):
            k = i // n_a
            w[i, used:] = 0.0
            if vm[i] == 0.0:
                w[i, :used] = 0.0
                continue
            _pair_row(px, py, pz, i, vm, used, scale, offset, d02, inv_sep, crowd, weight[b], w[i])
            w[i, k * n_a : (k + 1) * n_a] = 0.0


@njit(cache=True, nogil=True, inline="always")
def _profile_row(px, py, pz, vm, used, v, i, n_a, scale, offset, d02, inv_sep, crowd, weight,
                 row):  # fmt: skip
    """``row[m] = W[b, k, a, v, x_v]`` over the points ``m = k A + a`` of game b, from the
    point ``i = v A + x_v`` of variable v at its profile (0 where v is padding, on v's own
    points and past ``used``)."""
    row[used:] = 0.0
    if vm[i] == 0.0:
        row[:used] = 0.0
    else:
        _pair_row(px, py, pz, i, vm, used, scale, offset, d02, inv_sep, crowd, weight, row)
    row[v * n_a : (v + 1) * n_a] = 0.0


@njit(cache=True, nogil=True, parallel=True)
def _pair_at(profile, points, valid, scale, offset, d02, inv_sep, crowd, weight, out):
    """``out[b, l, k * A + a] = W[b, k, a, l, profile[b, l]]`` (B, K, K A): for every
    variable l, the row of its profile point against every point (k, a), whose squared
    differences are the table's bit for bit (W is symmetric)."""
    n_b, n_k, n_a = valid.shape
    for b in prange(n_b):
        px, py, pz, vm, used = _game_points(points, valid, b)
        for v in range(n_k):
            _profile_row(px, py, pz, vm, used, v, v * n_a + profile[b, v], n_a, scale, offset,
                         d02, inv_sep, crowd, weight[b], out[b, v])  # fmt: skip


@njit(cache=True, nogil=True, parallel=True)
def _pair_sums(profile, points, valid, scale, offset, d02, inv_sep, crowd, weight, sums, at_kl):
    """The rows of :func:`_pair_at` summed and read at the profile, without holding them:
    ``sums[b, k, a] = Σ_l W[b, k, a, l, profile[b, l]]``, in float32 from +0 in increasing
    l (numpy's order for the sum over the rows' outer axis), and ``at_kl[b, k, l] = W[b, k,
    profile[b, k], l, profile[b, l]]``. A zero entry changes no partial sum (+0 plus ±0 is
    +0), so the sums stop at each game's last valid point."""
    n_b, n_k, n_a = valid.shape
    n = n_k * n_a
    for b in prange(n_b):
        px, py, pz, vm, used = _game_points(points, valid, b)
        row = np.empty(n, np.float32)
        acc = sums[b].reshape(n)
        acc[:] = 0.0
        for v in range(n_k):
            _profile_row(px, py, pz, vm, used, v, v * n_a + profile[b, v], n_a, scale, offset,
                         d02, inv_sep, crowd, weight[b], row)  # fmt: skip
            for j in range(used):
                acc[j] += row[j]
            for k in range(n_k):
                at_kl[b, k, v] = row[k * n_a + profile[b, k]]


@dataclass(frozen=True, eq=False)
class CoveragePairs:
    """The coverage pairwise table W on demand (a
    :class:`~swarmgames.game.potentials.PairSource`, float32).

    .. math:: W[k, a, l, c] = w_b \\bigl(2 \\psi_R(d) - 2 c_{sep} m
        \\max(0, 1 - d / d_{sep})^2 / \\alpha_b^{pot}\\bigr), \\qquad
        d = \\lVert S_k(a) - S_l(c) \\rVert,

    for distinct valid variables and valid actions (0 elsewhere): the symmetrised eq. 6 plus
    the pairwise crowding penalty (``crowd`` = 0 when off) of
    :meth:`~swarmgames.missions.coverage.potentials.CoveragePotentials.pair_table` weighted
    by the engine's pairwise weight :math:`w_b` of game b, with its float32 arithmetic
    except that :math:`d^2` is the direct sum of squared differences in float64 (not a Gram
    product), the logarithm is :func:`log_f32` and the penalty is computed in float32: equal
    to it to float32 rounding (about 92 % of the entries bit for bit on a stage of 300 UAVs).

    Parameters
    ----------
    points : ndarray, shape (B, K, A, 3)
        Next positions, metres.
    valid : ndarray of bool, shape (B, K, A)
        Valid actions of valid variables.
    scale, offset, d02 : numpy.float32
        :math:`2\\psi_R = \\text{offset} + \\text{scale} \\log_{10} \\max(d^2, d_0^2)`.
        Both 0 for a table of the crowding penalty alone (no link term).
    inv_sep : numpy.float32
        :math:`1 / d_{sep}`, 1/metres (any value when ``crowd`` is 0).
    crowd : numpy.float32
        :math:`2 c_{sep} m / \\alpha_b^{pot}` (0: no crowding penalty).
    weight : ndarray of float32, shape (B,)
        The engine's pairwise weight of every game, :math:`\\alpha_b` or
        :math:`\\alpha_b / (K_b - 1)` (:func:`~swarmgames.game.potentials.pair_weights`).
    ids : ndarray of int64, shape (B, K), optional
        Which robot each variable is (``2 * member + is_virtual``); with it and ``rows``,
        :meth:`shared` ranks every game's variables by id and names the games that hold
        the same variables in another order.
    rows : ndarray of int64, shape (B, K), optional
        The stage row of every variable (``LocalGameBatch.rows``).
    repeats : EqualGames, optional
        The games that hold the same rows as an earlier one (``LocalGameBatch.equal_games``)
        when the source holds the batch's games in their order; :meth:`shared` finds them
        from ``rows`` otherwise.
    """

    points: np.ndarray
    valid: np.ndarray
    scale: np.float32
    offset: np.float32
    d02: np.float32
    inv_sep: np.float32
    crowd: np.float32
    weight: np.ndarray
    ids: np.ndarray | None = None
    rows: np.ndarray | None = None
    repeats: EqualGames | None = None

    #: ``at_sums``, ``shared`` and ``ranked_table``.
    capabilities: ClassVar[PairSourceCapabilities] = PairSourceCapabilities(
        at_sums=True, shared=True
    )

    def _consts(self):
        return (self.scale, self.offset, self.d02, self.inv_sep, self.crowd, self.weight)

    def table(self, games: np.ndarray) -> np.ndarray:
        """W of ``games``, (G, K, A, K, A) float32, a new array."""
        games = np.ascontiguousarray(games, dtype=np.int64)
        _, k, a = self.valid.shape
        out = np.empty((games.size, k, a, k, a), dtype=np.float32)
        with pool(in_parallel(games.size, (k * a) ** 2)):
            _pair_tables(games, self.points, self.valid, *self._consts(), out)
        return out

    def at(self, profile: np.ndarray) -> np.ndarray:
        """``W[b, k, a, l, profile[b, l]]``, (B, K, A, K) float32."""
        b, k, a = self.valid.shape
        out = np.empty((b, k, k * a), dtype=np.float32)
        prof = np.ascontiguousarray(profile, dtype=np.int64)
        with pool(in_parallel(b, k * k * a)):
            _pair_at(prof, self.points, self.valid, *self._consts(), out)
        return out.reshape(b, k, k, a).transpose(0, 2, 3, 1)

    def at_sums(self, profile: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``at(profile).sum(axis=3)``, (B, K, A), and ``W[b, k, profile[b, k], l,
        profile[b, l]]``, (B, K, K), both float32 and equal to what numpy makes of
        :meth:`at`'s rows bit for bit, without the (B, K, A, K) rows."""
        b, k, a = self.valid.shape
        sums = np.empty((b, k, a), dtype=np.float32)
        at_kl = np.empty((b, k, k), dtype=np.float32)
        prof = np.ascontiguousarray(profile, dtype=np.int64)
        with pool(in_parallel(b, k * k * a)):
            _pair_sums(prof, self.points, self.valid, *self._consts(), sums, at_kl)
        return sums, at_kl

    @cached_property
    def _order(self) -> np.ndarray:
        """Every game's variables sorted by id, valid first: ``order`` (B, K)."""
        key = np.where(self.valid.any(axis=2), self.ids, np.iinfo(np.int64).max)
        return np.argsort(key, axis=1, kind="stable")

    def shared(self) -> tuple[np.ndarray, np.ndarray] | None:
        """``(head, rank)`` of :class:`~swarmgames.game.potentials.PairSource`: every game's
        variables ranked by id (``2 * member + is_virtual``, the valid ones first), and
        games whose valid variables are the same rows with the same weight share the ranked
        table of the first of them. Each entry of W is computed from its two points alone,
        so their ranked tables are equal bit for bit. None without ids and rows; computed
        once per source."""
        return None if self.ids is None or self.rows is None else self._shared

    @cached_property
    def _shared(self) -> tuple[np.ndarray, np.ndarray]:
        b, k = self.ids.shape
        rank = np.empty_like(self._order)
        rank[np.arange(b)[:, None], self._order] = np.arange(k)
        head = np.arange(b)
        valid_vars = self.valid.any(axis=2)
        same = self.repeats
        if same is None:
            same = equal_games(self.rows, valid_vars)
        if same is not None:
            src = same.source
            cand = same.games[src.max(axis=1) // k]
            # A variable must hold its head's rank too (ids repeated inside a game would
            # break ties by position), and the game its head's weight: otherwise the game
            # keeps its own table.
            agree = (rank == rank[cand[:, None], np.maximum(src, 0) % k]) | ~valid_vars
            ok = agree.all(axis=1) & (self.weight[cand] == self.weight)
            head = np.where(ok, cand, head)
        return head, rank

    def ranked_table(self, games: np.ndarray) -> np.ndarray:
        """W of ``games`` with their variables in rank order (:meth:`shared`), (G, K, A, K,
        A) float32, a new array: the table of the game's points reordered, entry by entry
        equal to :meth:`table`'s."""
        games = np.ascontiguousarray(games, dtype=np.int64)
        order = self._order[games]
        rows = games[:, None]
        points = np.ascontiguousarray(self.points[rows, order])
        valid = np.ascontiguousarray(self.valid[rows, order])
        _, k, a = valid.shape
        out = np.empty((games.size, k, a, k, a), dtype=np.float32)
        consts = (*self._consts()[:-1], np.ascontiguousarray(self.weight[games]))
        with pool(in_parallel(games.size, (k * a) ** 2)):
            _pair_tables(np.arange(games.size), points, valid, *consts, out)
        return out

    def select(self, games) -> CoveragePairs:
        """The source of a subset of games."""
        return replace(
            self,
            points=self.points[games],
            valid=self.valid[games],
            weight=self.weight[games],
            ids=None if self.ids is None else self.ids[games],
            rows=None if self.rows is None else self.rows[games],
            repeats=None,
        )
