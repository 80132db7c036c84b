"""Potentials of the communication-aware coverage mission (paper eqs. 5 and 6).

For the local game of robot ``i`` with variables ``k`` (the owner and its neighbours, or their
virtual means :math:`\\bar S_j`, eq. 3), state :math:`S_k` and next state :math:`S_k(x_k)` after
action :math:`x_k`:

.. math::

    \\phi_u(k, x_k) &= \\int_\\mathcal{R} \\max\\Bigl\\{\\psi_R\\bigl(S_k(x_k), r\\bigr),
        \\max_{l \\ne k} \\psi_R(S_l, r)\\Bigr\\}\\, p(r)\\, dr \\qquad (4)

    \\phi_p(k, x_k, l, x_l) &= \\psi_R\\bigl(S_k(x_k), S_l(x_l)\\bigr) \\qquad (5)

The unary term is the expected best signal that the neighbourhood gives the ROI when ``k`` takes
action :math:`x_k` and the other variables stay at their (reported or virtual) states; the
pairwise term is the link quality between two neighbours after both moved. The integral is the
midpoint sum of :class:`~swarmgames.missions.coverage.roi.GaussianROI` (weights
:math:`p(r_g) a^2`, not
normalised: the unary is :math:`\\approx c\\,\\times` the mean signal in dBm). Signals are in
dBm and therefore negative at the distances of interest; the solver is invariant to a constant
shift of a variable's payoffs, so the sign does not matter to the game.

Computation (the cost is the unary's integral):

* every distinct position that appears in the batch (current states and next states; a real
  robot appears in many local games, a virtual mean in every local game that sees it) gets its
  signal field over the grid once per stage, in float32;
* per local game and grid cell the best and second-best current signal of its members are
  found once, so :math:`\\max_{l \\ne k}` costs O(1) per variable: it is the best unless ``k``
  holds the best, then the second best;
* the ``(games, variables, actions, cells)`` tensor is processed in chunks of local games so
  memory stays bounded for large swarms.

Three additions to the paper, each off when its weight is 0 (the defaults of
:class:`~swarmgames.config.CoverageConfig` switch them on, and ``docs/coverage.md`` shows
what each one changes):

Smooth maximum (``softness_db``): with the hard maximum of eq. 5 a robot whose signal is
nowhere the best in its neighbourhood (inside a clump, behind others) gains nothing from any
move, so it never leaves. :math:`\\tau \\ln(e^{a/\\tau} + e^{b/\\tau})` exceeds
:math:`\\max\\{a, b\\}` by at most :math:`\\tau \\ln 2` (at a tie) and by almost nothing
once the two differ by a few :math:`\\tau`, yet gives such robots a gradient. The coverage
*metric* keeps the hard maximum.

Crowding penalty (``separation_m``, ``separation_cost_db``): robots that take off from one
small area see almost the same neighbourhood, so eq. 5 gives them almost the same best move and
they fly in lockstep as a clump. A penalty that grows as a robot's next position comes within
:math:`d_{sep}` of another robot's current position depends on where each robot sits in the
clump, so neighbours choose different headings; it doubles as collision avoidance. With
``separation_mode = "pairwise"`` (the default) the penalty is a
pairwise potential of eq. 1 on *both* robots' next positions,
:math:`\\phi_{sep}(k, x_k, l, x_l) = -c_{sep} \\sum_g p(r_g) a^2
\\max(0, 1 - |S_k(x_k) - S_l(x_l)| / d_{sep})^2`, so the local game charges a joint move
where it ends. Scored in the unary against the others' *current* positions (``"unary"``), a
robot of a near co-located clump believes that any move escapes the penalty, every member
believes the same, the clump moves in lockstep, stays crowded, and the coverage term pulls it
back: a period-2 oscillation that never settles (20 UAVs, docs/coverage.md).

Move cost (``move_cost_db``): the switching cost of :class:`~swarmgames.game.inertia.Inertia`,
:math:`c_{move} \\sum_g p(r_g) a^2` on every move, added by the coverage mission
(:mod:`swarmgames.missions.coverage.mission`); it lets the swarm settle instead of swapping
neighbouring positions for ever.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop (arXiv 2205.02203), eqs. 1, 3, 5, 6.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from swarmgames.game.capabilities import PotentialCapabilities
from swarmgames.game.equal import CarriedGame
from swarmgames.game.rows import row_ids
from swarmgames.missions.coverage.links import LINK_CHUNK_ELEMS, LinkKeeping, LinkRisk
from swarmgames.missions.coverage.roi import GaussianROI
from swarmgames.missions.coverage.signal import SignalModel
from swarmgames.missions.coverage.window import (
    RoiRaster,
    floor_distance_sq,
    max_move,
    windowed_unary,
)
from swarmgames.missions.geometry import crowding_blocks, crowding_bytes

__all__ = ["KERNELS", "LINK_TERMS", "CoveragePotentials"]

#: Values of ``CoveragePotentials(kernel=...)`` (``coverage.kernel``).
KERNELS = ("auto", "compiled", "numpy")

#: Values of ``CoveragePotentials(link_term=...)`` (``coverage.link_term``).
LINK_TERMS = ("signal", "at_risk", "keep", "off")
#: What one metre outside a link-keeping disc costs, dB of expected ROI signal (times the
#: ROI's mass in the unary): far above the gain of any move, so that a robot leaves a disc
#: only where every action does.
KEEP_COST_DB_PER_M = 1.0

#: The integral's float32 temporaries per chunk entry and the pair table's float64
#: temporaries per entry of its blocks (a quarter of the chunk), for :meth:`stage_bytes`.
_UNARY_COPIES, _PAIR_COPIES = 5, 4


def _run_chunks(fn, starts, workers: int) -> None:
    """``fn(lo)`` for every start, on ``workers`` threads (numpy releases the GIL)."""
    if workers > 1 and len(starts) > 1:
        from concurrent.futures import ThreadPoolExecutor

        with ThreadPoolExecutor(workers) as pool:
            list(pool.map(fn, starts))
    else:
        for lo in starts:
            fn(lo)


#: Largest N x G signal field the coverage metric evaluates densely (bigger: a KD-tree query).
_DENSE_METRIC_ELEMS = 20_000_000

#: Largest signal field (bytes) the full-grid unary keeps from one batch to the next.
_KEPT_FIELD_BYTES = 64 * 2**20


def _batch_arrays(batch) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``mask`` (B, K), ``amask`` (B, K, A) (the valid actions of valid variables), and the
    positions of the states (B, K, 3) and next states (B, K, A, 3) of a batch."""
    mask = np.asarray(batch.mask, dtype=bool)
    amask = np.asarray(batch.action_mask, dtype=bool) & mask[..., None]
    states = np.asarray(batch.states, dtype=float)[..., :3]
    nxt = np.asarray(batch.next_states, dtype=float)[..., :3]
    return mask, amask, states, nxt


def _next_carry(carry, off, same, batch, computed):
    """The :class:`~swarmgames.game.equal.CarriedGame` a batch leaves for the next: its
    largest group of equal games (``same``, over ``carry`` and the batch when ``off`` is 1),
    with ``computed(g)``, the values of game g of ``same``; None when every game is alone."""
    mask = np.asarray(batch.mask, dtype=bool)
    arrays = carry.joined(batch.rows, mask) if off else (batch.rows, mask)
    return CarriedGame.largest(same, *arrays, computed, first=off)


def _groups(carry, batch):
    """``(same, off)``: the groups of equal games of ``carry`` (game 0, ``off`` = 1) and the
    batch when any batch game repeats it or another, else those of the batch alone
    (``batch.equal_games``, ``off`` = 0; ``same`` None when every game is alone)."""
    mask = np.asarray(batch.mask, dtype=bool)
    same = None if carry is None else carry.match(batch.rows, mask)
    return (same, 1) if same is not None else (batch.equal_games, 0)


#: Names of what the coverage potentials keep in a stage
#: (:meth:`~swarmgames.game.rows.StageRows.carry`) and a run
#: (:meth:`~swarmgames.game.kept.RowTables.table`).
_UNARY, _PAIRS, _FIELDS, _SIGNALS = (
    "coverage.unary", "coverage.pairs", "coverage.fields", "coverage.signals"
)  # fmt: skip


@dataclass(eq=False)
class CoveragePotentials:
    """Unary (eq. 5) and pairwise (eq. 6) potentials of the coverage mission.

    Parameters
    ----------
    roi : GaussianROI
        Region of interest and its integration grid.
    signal : SignalModel
        :math:`\\psi_R`.
    softness_db : float, default 0.0
        Temperature :math:`\\tau` (dB) of the smooth maximum that replaces
        :math:`\\max\\{a, b\\}` in eq. 5 by :math:`\\tau \\ln(e^{a/\\tau} + e^{b/\\tau})`
        (0 = the hard maximum). See the module notes.
    separation_m, separation_cost_db : float, default 0.0
        Crowding penalty: :math:`c_{sep} \\sum_g p(r_g) a^2 \\sum_{l \ne k}
        \\max(0, 1 - d(S_k(x_k), S_l) / d_{sep})^2` is subtracted from the unary (0 = off).
        See the module notes.
    separation_mode : {"pairwise", "unary"}, default "pairwise"
        Where the crowding penalty enters: the unary (each next position against the others'
        current positions) or the pairwise term (both next positions; :meth:`pairwise` and
        :meth:`pair_table` carry :math:`\\phi_{sep} / \\alpha_b`, so that the engine's
        weight :math:`\\alpha_b` gives it back its weight ``separation_cost_db``).
    alpha_b : float, default 0.001
        :math:`\\alpha_b` of eq. 1 (``game.alpha_b``); must be > 0 for the pairwise crowding
        penalty.
    chunk_elems : int, default 4_000_000
        Upper bound on the elements of one temporary ``(games, K, A, cells)`` block.
    workers : int, default 1
        Threads of the windowed integral (``signal_floor_dbm`` set).
    kernel : {"auto", "compiled", "numpy"}, default "auto"
        How the windowed integral is computed: the fused Numba kernel of
        :mod:`swarmgames.missions.coverage.kernel` (``"compiled"``; ``"auto"`` when Numba is
        importable) or numpy passes over (variables × actions × cells) blocks
        (:func:`~swarmgames.missions.coverage.window.windowed_unary`). The two agree to
        float32 rounding; each is bit-identical from run to run and on any number of threads.
        Without a signal floor the whole-grid integral is numpy's either way.
    signal_table_elems : int, default 96_000_000
        Upper bound on the float32 values (384 MiB; two states per id below that: 60 MiB at
        1 000 UAVs) of the run's table of states' action signals that the compiled windowed
        kernel keeps across batches and stages (:class:`~swarmgames.game.kept.KeptRows`, in
        the :class:`~swarmgames.game.kept.RowTables` the stage hands over): a state is
        computed once while it stays there. The results do not depend on it.
    link_term : {"signal", "at_risk", "keep", "off"}, default "signal"
        The link term: eq. 6's link quality :math:`\\psi_R` between next positions
        (pairwise); what a move takes from the links at risk
        (:mod:`~swarmgames.missions.coverage.links`, ``link_risk``, weighted by
        ``link_cost_db``; pairwise); the discs that keep the relative neighbour links
        (``link_keep``, in the unary: :data:`KEEP_COST_DB_PER_M` times the ROI's mass per
        metre outside); or none. Without eq. 6 the pairwise term is the crowding penalty
        (and the term at risk).
    link_risk : LinkRisk or None, default None
        The radio and margin of the link term at risk (``link_term = "at_risk"``).
    link_keep : LinkKeeping or None, default None
        The radio of link keeping (``link_term = "keep"``).
    link_cost_db : float, default 0.0
        :math:`c_{link}`: what one dB of shortfall on one link costs, in the unary's units
        (dB times the ROI's mass) (``link_risk`` set; > 0).
    signal_floor_dbm : float or None, default None
        Signals below this level count as the level in eq. 5, and each variable's unary is
        integrated only over the cells its actions can change, relative to what the other
        variables give there (:mod:`swarmgames.missions.coverage.window`): the unary then
        differs from
        eq. 5 by a term free of the variable's action, which changes no marginal and no
        deviation gain. None: the whole ROI (the paper's eq. 5 exactly).

    Attributes
    ----------
    last_integrate_s : float
        Wall time of the last :meth:`unary` call, seconds (the payoff integration time of
        the paper's Figure 2b).

    Notes
    -----
    Both methods take a batch of local games with the fields of the engine's
    ``LocalGameBatch``: ``mask (B, K)``, ``states (B, K, D)``, ``next_states (B, K, A, D)``
    and ``action_mask (B, K, A)``; the first three state coordinates are (x, y, z) in metres.
    Entries of padded variables or invalid actions are returned as 0.
    """

    roi: GaussianROI
    signal: SignalModel = field(default_factory=SignalModel)
    softness_db: float = 0.0
    separation_m: float = 0.0
    separation_cost_db: float = 0.0
    chunk_elems: int = 4_000_000
    signal_floor_dbm: float | None = None
    workers: int = 1
    separation_mode: str = "pairwise"
    alpha_b: float = 0.001
    kernel: str = "auto"
    signal_table_elems: int = 96_000_000
    link_term: str = "signal"
    link_risk: LinkRisk | None = None
    link_keep: LinkKeeping | None = None
    link_cost_db: float = 0.0
    last_integrate_s: float = field(default=0.0, init=False)
    #: Every optional form but the neighbourhood term.
    capabilities: ClassVar[PotentialCapabilities] = PotentialCapabilities(
        pair_table=True, pair_source=True, owner_rows=True, held_sharing=True, memory=True
    )
    _raster: RoiRaster | None = field(default=None, init=False, repr=False)

    def __post_init__(self) -> None:
        if self.separation_mode not in ("pairwise", "unary"):
            raise ValueError(
                f"separation_mode must be 'pairwise' or 'unary' (got {self.separation_mode!r})"
            )
        if self.kernel not in KERNELS:
            raise ValueError(
                f"kernel must be one of {', '.join(map(repr, KERNELS))} (got {self.kernel!r})"
            )
        if not (np.isfinite(self.alpha_b) and self.alpha_b >= 0):
            raise ValueError(f"alpha_b must be >= 0 and finite (got {self.alpha_b})")
        if self.link_term not in LINK_TERMS:
            raise ValueError(
                f"link_term must be one of {', '.join(map(repr, LINK_TERMS))} "
                f"(got {self.link_term!r})"
            )
        if (self.link_term == "at_risk") != (self.link_risk is not None):
            raise ValueError("link_risk must be given with link_term = 'at_risk', and only then")
        if (self.link_term == "keep") != (self.link_keep is not None):
            raise ValueError("link_keep must be given with link_term = 'keep', and only then")
        if self.link_risk is not None:
            if not (np.isfinite(self.link_cost_db) and self.link_cost_db > 0):
                raise ValueError(
                    f"link_cost_db must be > 0 and finite for the link term at risk "
                    f"(got {self.link_cost_db})"
                )
            if self.alpha_b == 0:
                raise ValueError(
                    "the link term at risk needs a pairwise weight > 0 (got alpha_b = 0, i.e. "
                    "game.alpha_b = 0)"
                )
        if self.separation_mode == "pairwise" and self._crowding_on and self.alpha_b == 0:
            raise ValueError(
                "the pairwise crowding penalty needs a pairwise weight > 0 (got alpha_b = 0, "
                "i.e. game.alpha_b = 0): set separation_mode = 'unary' or separation_cost_db = 0"
            )

    # ------------------------------------------------------------------ mission metrics
    def best_signal(self, positions: np.ndarray) -> np.ndarray:
        """Best signal over the swarm at every grid cell, dBm, shape (G,); ``positions``
        (N, >= 3), the first three columns (x, y, z) in metres."""
        pos = np.asarray(positions, dtype=float)[..., :3].reshape(-1, 3)
        if pos.shape[0] == 0:
            raise ValueError("positions must hold at least one robot (got 0)")
        pts = self.roi.points
        if pos.shape[0] * pts.shape[0] <= _DENSE_METRIC_ELEMS:
            return self.signal.field(pos, pts).max(axis=0)
        # ψ_R falls with distance: the best signal is the nearest UAV's (a KD-tree query
        # instead of an N x G field).
        from scipy.spatial import cKDTree

        ground = np.c_[pts, np.zeros(pts.shape[0])]
        d, _ = cKDTree(pos).query(ground, workers=self.workers)  # the same on any number
        return self.signal.power_sq((d * d).astype(np.float32), dtype=np.float32)

    def coverage(self, positions: np.ndarray) -> float:
        """Coverage of the ROI: the expected best signal,
        :math:`E[\\max_i \\psi_R(S_i, r) \\mid r \\in \\mathcal{R}]`, dBm."""
        return float(self.roi.expectation(self.best_signal(positions)))

    def coverage_moves_undone(self, positions: np.ndarray, previous: np.ndarray):
        """:meth:`coverage` of ``positions`` (N, >= 3) with each robot's move undone in turn
        (robot i at ``previous[i]``), (N,) dBm, bit for bit :meth:`coverage` of each such
        swarm: one signal field per position, and per cell the best and second-best current
        signal (so that the swarm without robot i's move holds the best of the others and
        robot i's previous signal). None where :meth:`coverage` takes the nearest UAV's
        signal instead of the fields (large swarms)."""
        pos = np.asarray(positions, dtype=float)[..., :3].reshape(-1, 3)
        prev = np.asarray(previous, dtype=float)[..., :3].reshape(-1, 3)
        n, pts = pos.shape[0], self.roi.points
        if n == 0 or prev.shape != pos.shape or n * pts.shape[0] > _DENSE_METRIC_ELEMS:
            return None
        fields = self.signal.field(np.concatenate([pos, prev]), pts)
        now, before = fields[:n], fields[n:]
        best_k = np.argmax(now, axis=0)
        best = now[best_k, np.arange(now.shape[1])]
        rest = now.copy()
        rest[best_k, np.arange(now.shape[1])] = -np.inf
        second = rest.max(axis=0)
        others = np.where(best_k[None, :] == np.arange(n)[:, None], second, best)
        return np.asarray(self.roi.expectation(np.maximum(others, before)), dtype=float)

    # ------------------------------------------------------------------ potentials
    def unary(self, batch) -> np.ndarray:
        """:math:`\\phi_u(k, x_k)` of eq. 5 for every game, variable and action, (B, K, A)."""
        t0 = time.perf_counter()
        mask, amask, states, nxt = _batch_arrays(batch)
        if amask.shape[0] == 0:
            self.last_integrate_s = time.perf_counter() - t0
            return np.zeros(amask.shape)
        if self._crowding_on and self.separation_mode == "unary":
            # The crowding sum runs in the order of the game's variables: no sharing.
            out = self._integral(batch, mask, amask, states, nxt)
            out -= self._crowding(mask, states, nxt)
        else:
            out = self._shared_integral(batch, mask, amask, states, nxt)
        if self.link_keep is not None:
            out -= self._keep_cost * self.link_keep.outside_m(batch)
        out[~amask] = 0.0
        self.last_integrate_s = time.perf_counter() - t0
        return out

    @property
    def _keep_cost(self) -> float:
        """What one metre outside a link-keeping disc costs in the unary."""
        return KEEP_COST_DB_PER_M * self.roi.mass

    def _integral(self, batch, mask, amask, states, nxt, games=None, rows=None) -> np.ndarray:
        """Eq. 5's integral of every game, variable and action, (B, K, A): over each
        variable's window of cells (``signal_floor_dbm`` set) or over the whole grid;
        ``games``: of those games of ``batch`` only (the arrays are theirs already, default
        all); ``rows`` (B, K) bool: only those variables (the windowed kernel; others 0)."""
        if self.signal_floor_dbm is not None:
            ids = row_ids(batch.members, batch.is_virtual)
            index = batch.rows
            if games is not None:
                ids, index = ids[games], index[games]
            return self._windowed(batch.stage, mask, amask, states, nxt, ids, index, rows)
        out = np.zeros(amask.shape)
        self._full_grid(batch.stage, out, mask, amask, states, nxt)
        return out

    def _shared_integral(self, batch, mask, amask, states, nxt, rows=None) -> np.ndarray:
        """:meth:`_integral`, computed once for every group of games that hold the same
        rows (``batch.equal_games``: the integral does not depend on the order of a game's
        variables), bit for bit. Over the whole grid (no signal floor), a game of the stage's
        previous batch is carried over too (:meth:`_carried_integral`)."""
        if rows is None and self.signal_floor_dbm is None:
            return self._carried_integral(batch, mask, amask, states, nxt)
        same = batch.equal_games
        if same is None:
            return self._integral(batch, mask, amask, states, nxt, rows=rows)
        g = same.games
        sub_rows = None if rows is None else same.rows(rows)
        part = self._integral(batch, mask[g], amask[g], states[g], nxt[g], g, sub_rows)
        return same.expand(part)

    def _carried_integral(self, batch, mask, amask, states, nxt) -> np.ndarray:
        """The whole-grid unary of every game, computed once per group of equal games of the
        batch and of the largest group of the stage's previous batch
        (:class:`~swarmgames.game.equal.CarriedGame`): a dense swarm's batches hold the same
        game, whose unary (0.03 s a batch at 300 UAVs, 100 batches of 3 games a float64
        stage) is then computed once a stage."""
        stage = batch.stage
        carry = stage.carried(self, _UNARY)
        same, off = _groups(carry, batch)
        if same is None:
            stage.carry(self, _UNARY, None)
            return self._integral(batch, mask, amask, states, nxt)
        heads = same.games[off:] - off  # the batch's games to compute
        part = self._integral(batch, mask[heads], amask[heads], states[heads], nxt[heads], heads)
        full = same.expand(np.concatenate([carry.computed[None], part]) if off else part)
        stage.carry(self, _UNARY, _next_carry(carry, off, same, batch, full.__getitem__))
        return full[off:]

    def owner_unary(self, batch) -> np.ndarray:
        """:math:`\\phi_u` of every game's variable 0 only, (B, A): ``unary(batch)[:, 0]``
        bit for bit, for the measurements that read only the owner's row (the global
        regret, the ex-post regret). The whole-grid integral and the compiled windowed
        kernel compute only those rows; the other paths compute every row."""
        whole = self.signal_floor_dbm is None
        compiled = whole or self._compiled
        if not compiled or (self._crowding_on and self.separation_mode == "unary"):
            return self.unary(batch)[:, 0]
        mask, amask, states, nxt = _batch_arrays(batch)
        if amask.shape[0] == 0:
            return np.zeros(amask.shape[::2])
        if whole:
            # Each game's owner deviates against its own others: no two games are equal.
            out = np.zeros(amask.shape)
            self._full_grid(batch.stage, out, mask, amask, states, nxt, owner_only=True)
            out = out[:, 0]
        else:
            owner = np.zeros(mask.shape, dtype=bool)
            owner[:, 0] = True
            out = self._shared_integral(batch, mask, amask, states, nxt, rows=owner)[:, 0]
        if self.link_keep is not None:
            out -= self._keep_cost * self.link_keep.outside_m(batch, owner_only=True)
        out[~amask[:, 0]] = 0.0
        return out

    def _windowed(self, stage, mask, amask, states, nxt, ids, index, rows=None) -> np.ndarray:
        """The unary over each variable's window of cells (``signal_floor_dbm`` set); the
        compiled kernel computes each stage row's action signals once (``index``, the
        rows of the variables) and keeps them in the run's table (``stage.kept``, when the
        stage has one)."""
        a = self.roi.cell_m
        reach = np.sqrt(floor_distance_sq(self.signal, self.signal_floor_dbm))
        r = int(np.ceil((reach + max_move(states, nxt, amask)) / a)) + 1
        if self._raster is None or self._raster.pad < r:
            self._raster = RoiRaster.from_roi(self.roi, r + 2)
        if self._compiled:
            from swarmgames.missions.coverage.kernel import compiled_windowed_unary

            kept = stage.kept
            signals = None if kept is None else kept.table(self, _SIGNALS, self.signal_table_elems)
            return compiled_windowed_unary(
                self._raster,
                self.signal,
                self.signal_floor_dbm,
                mask,
                amask,
                states,
                nxt,
                softness_db=self.softness_db,
                workers=self.workers,
                state_ids=ids,
                chunk_elems=self.chunk_elems // 2,
                rows=rows,
                signals=signals,
                row_index=index,
            )
        return windowed_unary(
            self._raster,
            self.signal,
            self.signal_floor_dbm,
            mask,
            amask,
            states,
            nxt,
            softness_db=self.softness_db,
            chunk_elems=self.chunk_elems // 2,
            workers=self.workers,
            state_ids=ids,
        )

    def _full_grid(self, stage, out, mask, amask, states, nxt, owner_only=False) -> None:
        """Eq. 4 over the whole ROI grid, written into ``out`` (B, K, A); ``owner_only``:
        variable 0's rows alone (the others stay as they are), each the same floats as in a
        whole evaluation (the same (A, G) @ (G,) product per variable)."""
        B, K, A = amask.shape
        rows = 1 if owner_only else K
        # One signal field per distinct position of the batch's variables and valid actions
        # (a padded variable's or an invalid action's entries read field 0: they are masked
        # out, and a (G,) product row does not depend on the other rows).
        valid = np.concatenate([mask.reshape(-1), amask.reshape(-1)])
        rows_xyz = np.concatenate([states.reshape(-1, 3), nxt.reshape(-1, 3)])[valid]
        inv = np.zeros(valid.size, dtype=np.intp)
        if rows_xyz.shape[0]:
            uniq, inv[valid] = np.unique(rows_xyz, axis=0, return_inverse=True)
        else:
            uniq = np.zeros((1, 3))
        fields = self._fields(stage, uniq)  # (U, G) float32
        cur_idx = inv[: B * K].reshape(B, K)
        nxt_idx = inv[B * K :].reshape(B, K, A)
        w = self.roi.weights.astype(np.float32)
        G = w.size
        # A chunk bounds both its (b, rows, A, G) values and its (b, K, G) current signals.
        step = max(1, self.chunk_elems // max(1, max(rows * A, K) * G))
        # A game whose (K, A, G) block alone exceeds the chunk takes its variables in slices.
        kstep = rows if step > 1 else max(1, self.chunk_elems // max(1, A * G))
        neg = np.float32(-np.inf)
        for lo in range(0, B, step):
            hi = min(B, lo + step)
            cur = np.where(mask[lo:hi, :, None], fields[cur_idx[lo:hi]], neg)  # (b, K, G)
            if owner_only:  # max over l != 0 (a max is exact: the floats of the other path)
                tail = cur[:, 1:] if K > 1 else np.full_like(cur, neg)
                spans = [(0, 1, tail.max(axis=1, keepdims=True))]
            else:
                best_k = np.argmax(cur, axis=1)  # (b, G)
                best = np.take_along_axis(cur, best_k[:, None, :], axis=1)  # (b, 1, G)
                rest = cur.copy()
                np.put_along_axis(rest, best_k[:, None, :], neg, axis=1)
                second = rest.max(axis=1, keepdims=True)  # (b, 1, G)
                del rest
                spans = [(k0, min(K, k0 + kstep), None) for k0 in range(0, K, kstep)]
            del cur
            for k0, k1, other in spans:
                if other is None:
                    holds_best = best_k[:, None, :] == np.arange(k0, k1)[None, :, None]
                    other = np.where(holds_best, second, best)  # (b, k, G): max over l != k
                f = fields[nxt_idx[lo:hi, k0:k1]]  # (b, k, A, G)
                o = other[:, :, None, :]
                val = np.maximum(f, o)
                if self.softness_db > 0:
                    tau = np.float32(self.softness_db)
                    val += tau * np.log1p(np.exp(-np.abs(f - o) / tau))
                out[lo:hi, k0:k1] = val @ w

    def _fields(self, stage, positions: np.ndarray) -> np.ndarray:
        """The signal of every position at every ROI cell, (U, G) float32; the stage's last
        batch's fields (up to ``_KEPT_FIELD_BYTES``, carried by ``stage``) are given back
        for the same positions
        (a stage's batches of a dense swarm hold the same robots: one field instead of one
        per batch), and so are their rows for positions among the kept ones (the ex-post
        games stand every robot where one of its actions of the stage's games took it). A
        field's rows are computed cell by cell, so a kept row is the row computed anew
        (tested)."""
        key = positions.tobytes()
        held = stage.carried(self, _FIELDS)
        if held is not None:
            held_key, index, held_fields = held
            if held_key == key:
                return held_fields
            rows = [index.get(p.tobytes(), -1) for p in positions]
            if min(rows, default=0) >= 0:
                fields = held_fields[rows]
                fields.flags.writeable = False
                return fields
        fields = self.signal.field(positions, self.roi.points)
        fields.flags.writeable = False
        kept = None
        if fields.nbytes <= _KEPT_FIELD_BYTES:
            kept = (key, {p.tobytes(): i for i, p in enumerate(positions)}, fields)
        stage.carry(self, _FIELDS, kept)
        return fields

    def _crowding(self, mask, states, nxt) -> np.ndarray:
        """Separation penalty of every next state against the others' current states,
        :math:`c_{sep} \\sum_g p_g a^2 \\sum_{l \\ne k} \\max(0, 1 - d_{kl} / d_{sep})^2`.

        Only pairs closer than :math:`d_{sep} + s` (``s`` the longest move) can be penalised,
        so the sum runs over those pairs (a segment sum in the order of ``l``)."""
        B, K, A = nxt.shape[:3]
        out = np.zeros((B, K, A))
        s_max = float(np.linalg.norm(nxt - states[:, :, None, :], axis=-1).max(initial=0.0))
        gb, gk, gl = np.nonzero(mask[:, :, None] & mask[:, None, :] & ~np.eye(K, dtype=bool))
        gap = np.linalg.norm(states[gb, gk] - states[gb, gl], axis=-1)
        near = gap < self.separation_m + s_max + 1e-9
        gb, gk, gl = gb[near], gk[near], gl[near]
        if gb.size == 0:
            return out
        d = np.linalg.norm(nxt[gb, gk] - states[gb, gl][:, None, :], axis=-1)  # (P, A)
        pen = np.maximum(0.0, 1.0 - d / self.separation_m) ** 2
        seg = gb * K + gk  # sorted by (b, k), then l
        starts = np.flatnonzero(np.r_[True, seg[1:] != seg[:-1]])
        out.reshape(B * K, A)[seg[starts]] = np.add.reduceat(pen, starts, axis=0)
        return self.separation_cost_db * self.roi.mass * out

    @property
    def _compiled(self) -> bool:
        """Whether the windowed integral runs the compiled kernel."""
        if self.kernel == "auto":
            from swarmgames.game.meanfield import compiled_available

            return compiled_available()
        return self.kernel == "compiled"

    @property
    def _crowding_on(self) -> bool:
        return self.separation_m > 0 and self.separation_cost_db > 0

    def _add_pair_crowding(self, out: np.ndarray, batch, games=None) -> None:
        """Add the symmetrised pairwise crowding penalty, divided by the pairwise weight, to
        ``out`` (B, K*A, K*A) in place:
        :math:`-2 c_{sep} \\sum_g p_g a^2 \\max(0, 1 - |S_k(a) - S_l(c)| / d_{sep})^2 /
        \\alpha_b`.

        Only variable pairs closer than :math:`d_{sep} + 2 s` (``s`` the longest move) can be
        penalised, so the (A, A) blocks of those pairs only are computed; ``games``: of those
        games only (default all)."""
        B, K, A = np.asarray(batch.action_mask).shape
        scale = 2.0 * self.separation_cost_db * self.roi.mass / self.alpha_b
        table = out.reshape(B, K, A, K, A)
        sub = batch if games is None else batch.select(games)
        for gb, gk, gl, pen in crowding_blocks(sub, self.separation_m):  # pen: (P, A, A)
            gb = gb if games is None else games[gb]
            table[gb, gk, :, gl, :] -= (scale * pen).astype(out.dtype)

    def _add_link_risk(self, table: np.ndarray, batch, games=None, first_only=False) -> None:
        """Add the symmetrised link term at risk to ``table`` (B, K', A, K, A), in place:
        :math:`-c_{link} m_{ROI} \\, \\mathrm{shortfall} / \\alpha_b` on the pairs linked now
        (:meth:`~swarmgames.missions.coverage.links.LinkRisk.blocks`); ``games``: of those
        games only (default all); ``first_only``: the owners' rows (K' = 1)."""
        scale = self.link_cost_db * self.roi.mass / self.alpha_b
        sub = batch if games is None else batch.select(games)
        for gb, gk, gl, short in self.link_risk.blocks(sub, first_only=first_only):
            gb = gb if games is None else np.asarray(games)[gb]
            rows = 0 if first_only else gk
            table[gb, rows, :, gl, :] -= (scale * short).astype(table.dtype)

    def pairwise(self, batch) -> np.ndarray:
        """:math:`\\phi_p(k, x_k, l, x_l)` of eq. 6, shape (B, K, K, A, A); 0 on the diagonal
        ``k == l`` and for padded variables or invalid actions. With the pairwise crowding
        penalty on, :math:`\\phi_{sep} / \\alpha_b` is added (module notes). With
        ``link_term`` other than ``"signal"``, the term at risk or none replaces eq. 6's
        (:mod:`~swarmgames.missions.coverage.links`; link keeping is in the unary)."""
        mask = np.asarray(batch.mask, dtype=bool)
        amask = np.asarray(batch.action_mask, dtype=bool) & mask[..., None]
        nxt = np.where(amask[..., None], np.asarray(batch.next_states, dtype=float)[..., :3], 0.0)
        B, K, A = amask.shape
        if self.link_term != "signal":
            # The symmetrised table holds each ordered pair's term twice (both are equal).
            table = self._pair_table(batch, np.dtype(np.float64)) / 2.0
            ok = amask[:, :, None, :, None] & amask[:, None, :, None, :]
            ok &= ~np.eye(K, dtype=bool)[None, :, :, None, None]
            return np.where(ok, table.transpose(0, 1, 3, 2, 4), 0.0)
        out = np.zeros((B, K, K, A, A))
        step = max(1, self.chunk_elems // max(1, K * K * A * A))
        # One game larger than the chunk (the centralised game: K = N) in slices of k.
        kstep = K if step > 1 else max(1, self.chunk_elems // max(1, K * A * A))
        off_diag = ~np.eye(K, dtype=bool)[None, :, :, None, None]
        for lo in range(0, B, step):
            hi = min(B, lo + step)
            b = nxt[lo:hi, None, :, None, :, :]  # (b, 1, K, 1, A, 3)
            for k0 in range(0, K, kstep):
                k1 = min(K, k0 + kstep)
                a = nxt[lo:hi, k0:k1, None, :, None, :]  # (b, k, 1, A, 1, 3)
                val = self.signal.link(a, b)
                if self._crowding_on and self.separation_mode == "pairwise":
                    gap = np.linalg.norm(a - b, axis=-1)
                    pen = np.maximum(0.0, 1.0 - gap / self.separation_m)
                    val = val - (self.separation_cost_db * self.roi.mass / self.alpha_b) * pen**2
                ok = (
                    amask[lo:hi, k0:k1, None, :, None]
                    & amask[lo:hi, None, :, None, :]
                    & off_diag[:, k0:k1]
                )
                out[lo:hi, k0:k1] = np.where(ok, val, 0.0)
        return out

    def stage_bytes(self, k: int, a: int, games: int, n: int) -> tuple[float, float, float]:
        """Working memory of evaluating one batch of ``games`` games of ``k`` variables and
        ``a`` actions in a swarm of ``n`` robots, ``(unary, owner_unary, pairwise)`` bytes
        (:func:`~swarmgames.sim.memory.estimate_memory`): the integral's chunks and its
        crowding blocks (the unary of the stage's games, before their table exists), the
        owners' rows of the ex-post and global regret (beside a table) and the pairwise
        blocks."""
        entries = float(games) * k * k * a * a
        g = self.roi.n_cells
        chunk = float(self.chunk_elems)
        if self.signal_floor_dbm is not None:
            # The windowed integral: each variable's disc of cells within the floor's reach
            # (plus the move and the window's margin), not the whole ROI.
            reach = math.sqrt(floor_distance_sq(self.signal, self.signal_floor_dbm))
            g = min(g, int(math.pi * (reach / self.roi.cell_m + 3.0) ** 2))
            fields = min(games * k, n) * (a + 1) * float(g)
            block = min(float(games) * k * a * g, max(chunk, float(a * g)))
            best = 2.0 * min(float(games), max(1.0, chunk / max(1, k * a * g))) * k * g
            unary = 4.0 * (_UNARY_COPIES * block + fields + best)
            owner = 0.0
            if self.kernel != "numpy":
                # The compiled kernel's table of states' signals kept across batches: at
                # most signal_table_elems values, two states per id (2 N + 2 ids).
                unary += 4.0 * min(float(self.signal_table_elems), 2.0 * (2 * n + 2) * a * g)
        else:
            # The whole grid. Games that hold every robot (K = N) hold the same states under
            # exact delivery and are integrated once; the others each (in chunks). The
            # owners' rows (ex-post and global regret) take chunks of games of (1, A, G)
            # values and (K, G) current signals, from the positions' fields (kept ones
            # gathered by position), and the last field (up to _KEPT_FIELD_BYTES) is kept
            # from one batch to the next.
            distinct = 1 if k >= n else games
            fields = min(games * k, n) * (a + 1) * float(g)
            block = min(float(distinct) * k * a * g, max(chunk, float(a * g)))
            best = 2.0 * min(float(distinct), max(1.0, chunk // max(1, k * a * g))) * k * g
            kept = min(4.0 * fields, float(_KEPT_FIELD_BYTES))
            unary = 4.0 * (_UNARY_COPIES * block + fields + best) + kept
            rows = min(float(games), max(1.0, chunk // max(1, max(a, k) * g)))
            owner = 4.0 * (_UNARY_COPIES * rows * a * g + 2.0 * rows * k * g + fields) + kept
        pair = 8.0 * _PAIR_COPIES * min(entries, max(self.chunk_elems / 4, k * a))
        if self.separation_m > 0 and self.separation_cost_db > 0:
            pair += crowding_bytes(entries)
        if self.link_risk is not None:
            # The computed table (never on demand) and the shortfall blocks' temporaries.
            pair += 8.0 * entries + 8.0 * _PAIR_COPIES * min(entries, float(LINK_CHUNK_ELEMS))
        if self.link_keep is not None:
            # Link keeping: the pairs of every game (a flag, their indices and distances) and
            # the witness search's chunk of distances (three float64 copies).
            keep = float(games) * k * k * (1.0 + 4.0 * 8.0)
            keep += 3.0 * 8.0 * min(float(games) * k * k * k, float(LINK_CHUNK_ELEMS))
            unary += keep
            owner += keep
        return unary, owner, pair

    def pair_on_demand(self, dtype) -> bool:
        """Whether :meth:`pair_source` gives a source for tables of ``dtype`` (float32 with
        the compiled kernel, with eq. 6's link term or none)."""
        return np.dtype(dtype) == np.float32 and self._compiled and self.link_term != "at_risk"

    def held_sharing_min(self, dtype) -> int | None:
        """The valid entries from which a batch's equal games share one held table of
        ``dtype`` (:meth:`_held_pairs`, float64:
        :data:`~swarmgames.game.held.HELD_SHARE_MIN`); None for float32, whose tables are
        computed on demand."""
        from swarmgames.game.held import HELD_SHARE_MIN

        return HELD_SHARE_MIN if np.dtype(dtype) == np.float64 else None

    def pair_source(self, batch, weights, dtype=np.float64):
        """The engine's weighted table :math:`w_b \\times` :meth:`pair_table` (``weights``:
        each game's pairwise weight :math:`w_b`, shape (B,), or one α_b for all), on
        demand (:class:`~swarmgames.missions.coverage.kernel.CoveragePairs`: computed per
        chunk of games inside the compiled mean-field solve and at the measured profiles,
        never for the whole batch), for float32 tables with the compiled kernel and eq. 6's
        link term or none (``link_term = "off"`` or ``"keep"``: the source's signal part is
        0, its scale and offset 0); None otherwise (the engine then calls
        :meth:`pair_table`). Equal to it to float32 rounding."""
        if np.dtype(dtype) == np.float64:
            return self._held_pairs(batch, weights)
        if not self.pair_on_demand(dtype):
            return None
        from swarmgames.missions.coverage.kernel import CoveragePairs

        sig = self.signal
        mask = np.asarray(batch.mask, dtype=bool)
        valid = np.asarray(batch.action_mask, dtype=bool) & mask[..., None]
        d02 = np.float32(sig.reference_distance_m**2)
        crowd = self._crowding_on and self.separation_mode == "pairwise"
        link = self.link_term == "signal"
        return CoveragePairs(
            points=np.ascontiguousarray(np.asarray(batch.next_states, dtype=float)[..., :3]),
            valid=np.ascontiguousarray(valid),
            scale=np.float32(-10.0 * sig.exponent if link else 0.0),
            offset=np.float32(
                2.0 * (sig.t0_dbm - sig.l0_db) + 10.0 * sig.exponent * np.log10(d02)
                if link
                else 0.0
            ),
            d02=d02,
            inv_sep=np.float32(1.0 / self.separation_m if crowd else 0.0),
            crowd=np.float32(
                2.0 * self.separation_cost_db * self.roi.mass / self.alpha_b if crowd else 0.0
            ),
            weight=np.ascontiguousarray(
                np.broadcast_to(np.asarray(weights, dtype=np.float32), mask.shape[:1])
            ),
            ids=row_ids(batch.members, batch.is_virtual),
            rows=batch.rows,
            repeats=batch.equal_games,
        )

    def _held_pairs(self, batch, weights):
        """The float64 tables of a batch whose large games repeat one another (or the stage's
        carried game) as :class:`~swarmgames.game.held.HeldPairs`, one weighted table per
        group; None when no group of at least two games has
        :data:`~swarmgames.game.held.HELD_SHARE_MIN` valid entries (the engine then takes
        :meth:`pair_table`, a table per game)."""
        from swarmgames.game.held import HELD_SHARE_MIN, HeldPairs
        from swarmgames.game.potentials import weighted_pair_table

        mask, amask, _, _ = _batch_arrays(batch)
        b, k, a = amask.shape
        if not np.any(mask.sum(axis=1) * a >= HELD_SHARE_MIN):
            return None  # no game large enough to share a table: no need to group them
        carry = batch.stage.carried(self, _PAIRS)
        same, off = _groups(carry, batch)
        if same is None:
            return None
        src = same.source[off:]
        group = np.maximum(src, 0).max(axis=1) // k  # its head's index in same.games
        count = np.bincount(group, minlength=same.games.size)
        if not np.any((count[group] >= 2) & (mask.sum(axis=1) * a >= HELD_SHARE_MIN)):
            return None
        used, group = np.unique(group, return_inverse=True)
        group = group.reshape(-1)
        first = np.full(used.size, b, dtype=np.int64)
        np.minimum.at(first, group, np.arange(b))  # every group's first game of the batch
        w = np.broadcast_to(np.asarray(weights, dtype=float), (b,))
        if np.any(w != w[first[group]]):  # a group's games must weigh alike
            return None
        var = np.where(src >= 0, src % k, 0)
        carried = off == 1 and same.games[used[0]] == 0  # group 0 reads the carried table
        own = np.empty((used.size, k, a, k, a))
        todo = first[1:] if carried else first
        if todo.size:
            own[int(carried) :] = self._pair_table(batch.select(todo), np.dtype(np.float64))
        if carried:
            # Into the order of the batch's first game of the group; its games' variables
            # then index that game's, not the carried game's.
            g = first[0]
            v = var[g]
            own[0] = carry.computed.take(v, axis=0).take(v, axis=2)
            inv = np.zeros(k, dtype=np.int64)
            inv[v[mask[g]]] = np.flatnonzero(mask[g])
            sel = group == 0
            var[sel] = np.where(mask[sel], inv[var[sel]], 0)
        # The largest group's game is carried to the next batch (unweighted: before the
        # weights scale ``own`` in place). A head of same is the carried game or its group's
        # first batch game, whose own-order table ``own`` holds.
        batch.stage.carry(self, _PAIRS, _next_carry(
            carry, off, same, batch,
            lambda g: carry.computed if off and g == 0 else own[group[g - off]],
        ))  # fmt: skip
        weighted = weighted_pair_table(batch.select(first), lambda *_: own, w[first], np.float64)
        return HeldPairs(weighted, group, var, mask.copy(), mask[first].copy())

    def pair_table(self, batch, dtype=np.float64) -> np.ndarray:
        """Symmetrised eq. 6 in the engine's layout, ``(B, K, A, K, A)``:
        :math:`\\phi_p(k, a, l, c) + \\phi_p(l, c, k, a) = 2\\,\\psi_R(|S_k(a) - S_l(c)|)`
        (the engine's cheaper form of :meth:`pairwise`; a new array), plus
        :math:`2 \\phi_{sep} / \\alpha_b` with the pairwise crowding penalty on; entries of
        padding and invalid actions are finite but meaningless.

        In float64 the values equal :meth:`pairwise` bit for bit, and every entry is computed
        from its two points alone, so the games of a batch that hold the same robots in the
        same states (:mod:`~swarmgames.game.equal`) are computed once and the
        others' tables are copies of it with their variables reordered, bit for bit. In
        float32 the squared distances come from one batched product per game,
        :math:`|p|^2 + |q|^2 - 2 p \\cdot q` in float64 on coordinates relative to the game's
        first position, and the logarithm in float32."""
        dtype = np.dtype(dtype)
        if dtype != np.float64:
            return self._pair_table(batch, dtype)
        stage = batch.stage
        carry = stage.carried(self, _PAIRS)
        same, off = _groups(carry, batch)
        stage.carry(self, _PAIRS, None)
        if same is None:
            return self._pair_table(batch, dtype)
        # The first game of every group is computed in place, the others copied from it (or
        # from the stage's carried game, game 0 of ``same``, when ``off`` is 1: a
        # dense float64 swarm's batches then compute one table a stage, not one a batch).
        heads = same.games[off:] - off
        if heads.size:
            out = self._pair_table(batch, dtype, games=heads)
        else:
            b, k, a = np.shape(batch.action_mask)
            out = np.empty((b, k, a, k, a), dtype=dtype)
        same.expand_pairs(out, carry.computed if off else None)
        stage.carry(self, _PAIRS, _next_carry(
            carry, off, same, batch, lambda g: carry.computed if off and g == 0 else out[g - off]
        ))  # fmt: skip
        return out

    def owner_pair_table(self, batch, dtype=np.float64) -> np.ndarray | None:
        """Row 0 of :meth:`pair_table`, ``(B, A, K, A)``: ``pair_table(batch, dtype)[:, 0]``
        bit for bit (every float64 entry is computed from its two points alone, the crowding
        penalty of each pair of variables alike), for the measurements that read only the
        owners' rows (the global and ex-post regret); None for float32 (its squared
        distances come from one product per game, whose rows are not computed alone)."""
        dtype = np.dtype(dtype)
        if dtype != np.float64:
            return None
        nxt = np.asarray(batch.next_states, dtype=float)[..., :3]
        B, K, A = nxt.shape[:3]
        if self.link_term != "signal":
            out = np.zeros((B, A, K, A), dtype=dtype)
            if self.link_risk is not None:
                self._add_link_risk(out[:, None], batch, first_only=True)
            if self._crowding_on and self.separation_mode == "pairwise":
                scale = 2.0 * self.separation_cost_db * self.roi.mass / self.alpha_b
                for gb, _, gl, pen in crowding_blocks(batch, self.separation_m, first_only=True):
                    out[gb, :, gl, :] -= (scale * pen).astype(out.dtype)
            return out
        pts = nxt.reshape(B, K * A, 3)
        out = np.empty((B, A, K * A), dtype=dtype)
        step = max(1, self.chunk_elems // 4 // max(1, A * K * A))
        sig = self.signal
        for lo in range(0, B, step):
            p = pts[lo : lo + step]
            q = p[:, :A]
            diff = q[:, :, None, 0] - p[:, None, :, 0]
            d2 = diff * diff
            for c in (1, 2):
                diff = q[:, :, None, c] - p[:, None, :, c]
                d2 += diff * diff
            val = sig.power_sq(d2.astype(dtype, copy=False), dtype=dtype.type)
            np.add(val, val, out=out[lo : lo + step])
        if self._crowding_on and self.separation_mode == "pairwise":
            scale = 2.0 * self.separation_cost_db * self.roi.mass / self.alpha_b
            table = out.reshape(B, A, K, A)
            for gb, _, gl, pen in crowding_blocks(batch, self.separation_m, first_only=True):
                table[gb, :, gl, :] -= (scale * pen).astype(out.dtype)
        return out.reshape(B, A, K, A)

    def _pair_table(self, batch, dtype, games=None) -> np.ndarray:
        """:meth:`pair_table` of every game of ``batch``, each computed; ``games`` (float64
        only): of those games only, the others' rows left unset."""
        nxt = np.asarray(batch.next_states, dtype=float)[..., :3]
        B, K, A = nxt.shape[:3]
        if self.link_term != "signal":
            out = np.zeros((B, K * A, K * A), dtype=dtype)
            if self.link_risk is not None:
                self._add_link_risk(out.reshape(B, K, A, K, A), batch, games)
            if self._crowding_on and self.separation_mode == "pairwise":
                self._add_pair_crowding(out, batch, games)
            return out.reshape(B, K, A, K, A)
        pts = nxt.reshape(B, K * A, 3)
        out = np.empty((B, K * A, K * A), dtype=dtype)
        step = max(1, self.chunk_elems // 4 // max(1, (K * A) ** 2))
        sig = self.signal
        if dtype == np.float32:
            rel = pts - pts[:, :1]
            sq = np.einsum("bic,bic->bi", rel, rel)
            d02 = np.float32(sig.reference_distance_m**2)
            scale = np.float32(-10.0 * sig.exponent)  # 2 ψ = 2 (T0 - L0) - 10 n log10(d²/d0²)
            offset = np.float32(
                2.0 * (sig.t0_dbm - sig.l0_db) + 10.0 * sig.exponent * np.log10(d02)
            )

            def chunk(lo: int) -> None:
                hi = min(B, lo + step)
                d2 = out[lo:hi]
                r = rel[lo:hi]
                # |p - q|² = |p|² + |q|² - 2 p·q in float64 (no cancellation loss), then float32.
                g = np.matmul(r, r.transpose(0, 2, 1))
                g *= -2.0
                g += sq[lo:hi, :, None]
                g += sq[lo:hi, None, :]
                d2[...] = g
                np.maximum(d2, d02, out=d2)
                np.log10(d2, out=d2)
                d2 *= scale
                d2 += offset

            _run_chunks(chunk, range(0, B, step), self.workers)
            if self._crowding_on and self.separation_mode == "pairwise":
                self._add_pair_crowding(out, batch)
            return out.reshape(B, K, A, K, A)
        # A game whose (K A)² table alone exceeds the chunk is done in blocks of rows (one
        # K = 300 game: 58 MB per temporary otherwise); every entry is computed alike.
        rows = K * A if step > 1 else max(1, self.chunk_elems // 4 // max(1, K * A))
        todo = np.arange(B) if games is None else np.asarray(games)
        for lo in range(0, todo.size, step):
            at = todo[lo : lo + step]
            if at[-1] - at[0] + 1 == at.size:  # a run of games: write in place
                at = slice(int(at[0]), int(at[-1]) + 1)
            p = pts[at]
            for r0 in range(0, K * A, rows):
                q = p[:, r0 : r0 + rows]
                diff = q[:, :, None, 0] - p[:, None, :, 0]
                d2 = diff * diff
                for c in (1, 2):
                    diff = q[:, :, None, c] - p[:, None, :, c]
                    d2 += diff * diff
                val = sig.power_sq(d2.astype(dtype, copy=False), dtype=dtype.type)
                if isinstance(at, slice):
                    np.add(val, val, out=out[at, r0 : r0 + rows])
                else:
                    out[at, r0 : r0 + rows] = val + val
        if self._crowding_on and self.separation_mode == "pairwise":
            self._add_pair_crowding(out, batch, games)
        return out.reshape(B, K, A, K, A)
