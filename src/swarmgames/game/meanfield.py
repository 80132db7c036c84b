"""Mean-field inference over local games (paper Algorithm 1), batched over games.

Each variable X_k of a local game gets a marginal Q_k over its actions; the joint is
approximated by the product Q = Π_k Q_k. Starting from the unary term alone,

    Q_k(x) ∝ exp(β · U[k, x])                                          (Algorithm 1, line 5)

the coordinate update of variable k given the others' marginals is

    Q_k(x) ∝ exp(β · E_{Q_-k}[M | X_k = x]),
    E_{Q_-k}[M | X_k = x] = U[k, x] + Σ_{l≠k} Σ_c Q_l(c) W[k, x, l, c] + (terms free of x),

with ``U = α_a φ_u`` and ``W[k, x, l, c] = α_b (φ_p(k, x, l, c) + φ_p(l, c, k, x))`` (see
:mod:`swarmgames.game.potentials`); terms that do not involve x cancel in the normalisation.

Sign convention
---------------
The paper writes Q ∝ exp(−M) (energy minimisation over an MRF) while its robots maximise the
payoff M. This module maximises payoff: Q_k(x) ∝ exp(+β E[M | x]) with an inverse temperature
β > 0 in units of 1/payoff. To reproduce the energy form, negate the potentials. As β → ∞ the
update becomes a best response, and a fixed point is a pure Nash equilibrium of the local game
(the local game is a potential game with potential M).

Schedule and stopping
---------------------
Algorithm 1 picks one variable at a time. Here one *sweep* updates k = 0, 1, ..., K−1 in turn
(Gauss-Seidel order), each update vectorised over all B games. After each sweep the stopping
rule is tested per game,

    KL(Q_old ‖ Q) = Σ_k Σ_x Q_old,k(x) log(Q_old,k(x) / Q_k(x)) < δ,

(the KL divergence of two product distributions is the sum of the per-variable ones), with
Q_old the marginals before the sweep. A game stops at its first sweep with KL < δ
(``converged``) or after ``max_iter`` sweeps (not converged); a stopped game is never updated
again, so each game's result does not depend on the other games of the batch.

Engines
-------
``engine="compiled"`` (the default, ``"auto"``, when Numba is installed) runs
:mod:`swarmgames.game.meanfield_compiled`: one compiled call solves every game of the batch to
convergence, game by game on all cores, each game's table staying in cache across its sweeps.
A game gives bit-identical results alone, inside any batch, padded to any width and on any
number of threads.

The two numpy engines update variable k of all games of the batch with a few numpy calls per
variable (the reference implementation, and the fallback without Numba). Every game is still
computed by its own arithmetic: a game solved inside a batch and the same game (same padded
width K) solved alone give bit-identical results, whatever the other games are. Padding only
adds exact zeros; with ``engine="sequential"`` every sum runs in a fixed sequential order
(column by column, never numpy's pairwise summation), so a game also gives bit-identical
results whatever its padded width. With ``engine="blas"`` the pairwise expectation is a BLAS
product, whose blocking depends on the vector length: across different widths K the marginals
then agree to rounding (~1e-15 relative), not bit for bit. The engines agree with one another
to rounding.

Wide sums
---------
A float32 game of at least :data:`WIDE_SUM_MIN` valid entries (valid variables × actions, a
dense swarm's game) sums its pair fields in float64 in every engine, and takes its logits
and softmax in float64 before rounding Q to float32: summed in float32, the rounding of
thousands of terms makes the marginals dither around the fixed point by more than the KL
test's δ, and such games ran to ``max_iter``. Whether a game is wide depends on it alone.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, Algorithm 1 and eq. 2.
.. [2] D. Koller and N. Friedman, *Probabilistic Graphical Models*, MIT Press, 2009,
   section 11.5 (mean-field approximation, coordinate ascent).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swarmgames.arrays import freeze_fields
from swarmgames.game.potentials import (
    GamePayoffs,
    _check_empty_actions,
    ranked_chunks,
    shared_tables,
)
from swarmgames.names import ENGINES

__all__ = [
    "ENGINES",
    "WIDE_SUM_MIN",
    "MeanFieldResult",
    "compiled_available",
    "masked_softmax",
    "mean_field",
    "resolve_engine",
    "seq_sum",
]

"""Values of ``mean_field(engine=...)``."""

WIDE_SUM_MIN = 1024
"""Float32 games of at least this many valid entries (valid variables × actions) sum their
pair fields, logits and softmax in float64 (module docstring, "Wide sums")."""


def compiled_available() -> bool:
    """Whether the compiled engine can run (Numba importable)."""
    try:
        import numba  # noqa: F401
    except ImportError:
        return False
    return True


def resolve_engine(engine: str) -> str:
    """The engine that ``mean_field(engine=engine)`` runs (``"auto"`` resolved).

    Raises
    ------
    ValueError
        An unknown engine.
    BackendUnavailableError
        ``"compiled"`` without Numba.
    """
    if engine not in ENGINES:
        raise ValueError(f"engine must be one of {', '.join(map(repr, ENGINES))} (got {engine!r})")
    if engine == "auto":
        return "compiled" if compiled_available() else "blas"
    if engine == "compiled" and not compiled_available():
        from swarmgames.errors import BackendUnavailableError

        raise BackendUnavailableError(
            "the compiled mean-field engine needs Numba: pip install numba (or use engine='blas')"
        )
    return engine


def seq_sum(x: np.ndarray, axis: int = -1) -> np.ndarray:
    """Sum along ``axis`` in strict sequential order (padding-invariant, unlike ``np.sum``'s
    pairwise summation)."""
    return np.take(np.cumsum(x, axis=axis), -1, axis=axis)


def masked_softmax(logits: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """``exp(logits)`` normalised over the last axis where ``mask``; exactly 0 elsewhere, and
    all zeros for a row with no valid entry."""
    z = np.where(mask, logits, -np.inf)
    m = z.max(axis=-1, keepdims=True)
    m = np.where(np.isfinite(m), m, 0.0)
    e = np.exp(z - m)
    s = seq_sum(e)[..., None]
    return e / np.where(s > 0, s, 1.0)


def _colsum(x: np.ndarray) -> np.ndarray:
    """Sum over the last axis, column by column (fixed order, no pairwise summation): the same
    bits whatever the leading shape, and numpy's short-row reductions are slow anyway."""
    out = x[..., 0].copy()
    for c in range(1, x.shape[-1]):
        out += x[..., c]
    return out


def _softmax(z: np.ndarray) -> np.ndarray:
    """In-place softmax over the last axis of finite-max logits (``-inf`` entries give 0)."""
    # A maximum is exact in any order: one reduction instead of a loop over the columns.
    z -= z.max(axis=-1, keepdims=True)
    np.exp(z, out=z)
    # The action axis has the same length in every game of a batch and alone (only K is
    # padded), so numpy's own reduction keeps batched and single solves bit-identical.
    z /= z.sum(axis=-1, keepdims=True)
    return z


def _kl(q_old: np.ndarray, q: np.ndarray) -> np.ndarray:
    """KL(Q_old ‖ Q) of product distributions, per game: (B, K, A) -> (B,).

    Summed over the actions, then over the variables, each in sequential order. Column by
    column (A + K numpy calls over all games) or, for a few games, by two cumulative sums
    (two calls, but a per-row loop): the same bits either way.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        terms = np.where(q_old > 0, q_old * (np.log(q_old) - np.log(q)), 0.0)
    if terms.shape[0] * terms.shape[1] <= _FEW_ROWS:
        return seq_sum(seq_sum(terms))
    return _colsum(_colsum(terms))


_FEW_ROWS = 128
"""Games × variables up to which :func:`_kl` sums by cumulative sums (measured crossover)."""


@dataclass(frozen=True, eq=False)
class MeanFieldResult:
    """Output of :func:`mean_field`.

    Parameters
    ----------
    marginals : ndarray, shape (B, K, A)
        Q_k(x); rows sum to 1 on valid variables, 0 on padding and invalid actions.
    iterations : ndarray of int, shape (B,)
        Sweeps performed (>= 1).
    converged : ndarray of bool, shape (B,)
        KL < δ reached before ``max_iter``.
    kl : ndarray, shape (B,)
        KL(Q_old ‖ Q) of the last sweep.
    """

    marginals: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray
    kl: np.ndarray

    def __post_init__(self) -> None:
        freeze_fields(self)


def _pair_field(w: np.ndarray, q: np.ndarray, k: int, sequential: bool, wide: bool = False):
    """Σ_l Σ_c W[:, k, x, l, c] Q_l(c) for every game and action x, (B, A); in float64 from
    float64 copies of the operands when ``wide`` (each float32 product is then exact)."""
    nw, _, a = q.shape
    cast = (lambda x: x.astype(np.float64)) if wide else (lambda x: x)
    if not sequential:
        # One batched matrix-vector product per game over the flattened (l, c) axis (BLAS).
        m = w.shape[3] * a
        return np.matmul(cast(w[:, k].reshape(nw, a, m)), cast(q.reshape(nw, m, 1)))[:, :, 0]
    # Element-wise products accumulated over c in a fixed order, then a sequential sum over l:
    # padding adds exact zeros, so the result does not depend on K.
    acc = cast(w[:, k, :, :, 0]) * cast(q[:, None, :, 0])
    for c in range(1, a):
        acc += cast(w[:, k, :, :, c]) * cast(q[:, None, :, c])
    return _colsum(acc)


_COPY_FRACTION = 0.75
"""Copy the working set once fewer than this fraction of its games are still running."""


def _compact(running: np.ndarray, *arrays):
    """Keep the rows where ``running`` as a prefix of each array (row order not kept).

    Every stopped row among the first n = running.sum() is overwritten by a running row from
    beyond n, so the move costs as many row copies as games stopped there, not a copy of the
    whole set; the arrays are then cut to their first n rows (views). ``None`` passes through.
    """
    n = int(running.sum())
    dst = np.flatnonzero(~running[:n])
    src = n + np.flatnonzero(running[n:])
    out = []
    for x in arrays:
        if x is not None and dst.size:
            x[dst] = x[src]
        out.append(None if x is None else x[:n])
    return out


def _sweep_loop(
    w, q: np.ndarray, logits: np.ndarray, beta_t, sequential: bool, wide: bool = False
) -> None:
    """One Gauss-Seidel sweep over the variables, in place on ``q`` (sequential sums, or no
    pairwise table)."""
    for k in range(q.shape[1]):
        if w is not None:
            # β·(Σ_l Σ_c W Q) + β·U, in place on the fresh pair field (same bits as
            # β·U + β·(...): IEEE addition is commutative).
            z = _pair_field(w, q, k, sequential, wide)
            z *= beta_t
            z += logits[:, k]
        else:
            z = logits[:, k].copy()
        q[:, k] = _softmax(z)


def _blas_sweep(w: np.ndarray, q: np.ndarray, logits: np.ndarray, beta_t, wide: bool = False):
    """A Gauss-Seidel sweep with BLAS pair fields over this working set, in place on ``q``.

    The same operations, in the same order, as :func:`_pair_field` followed by
    :func:`_softmax`, with the per-variable views made once per working set, the reductions
    written into one preallocated buffer and the normalised row straight into ``q[:, k]``:
    fewer numpy calls per variable, which is what a sweep over a few games costs (about 5 µs
    per variable, whatever the number of games).

    Returns
    -------
    callable
        ``sweep()``, valid while ``w``, ``q`` and ``logits`` keep their rows.
    """
    nw, k_vars, a = q.shape
    m = k_vars * a
    qv = q.reshape(nw, m, 1)
    wv = w.reshape(nw, k_vars, a, m)
    red = np.empty((nw, 1), dtype=np.float64 if wide else q.dtype)
    steps = [(wv[:, k], logits[:, k], q[:, k]) for k in range(k_vars)]

    def sweep() -> None:
        for w_k, logits_k, q_k in steps:
            if wide:  # float64 copies (module docstring, "Wide sums")
                z = _matmul(w_k.astype(np.float64), qv.astype(np.float64))[:, :, 0]
            else:
                z = _matmul(w_k, qv)[:, :, 0]
            _multiply(z, beta_t, z)
            _add(z, logits_k, z)
            _max_reduce(z, -1, None, red, True)
            _subtract(z, red, z)
            _exp(z, z)
            _add_reduce(z, -1, None, red, True)
            _divide(z, red, q_k)

    return sweep


# Bound once: each call in the sweep above is a few hundred nanoseconds of dispatch.
_matmul, _multiply, _add, _subtract, _exp, _divide = (
    np.matmul,
    np.multiply,
    np.add,
    np.subtract,
    np.exp,
    np.divide,
)
_max_reduce, _add_reduce = np.maximum.reduce, np.add.reduce


def _mean_field_compiled(
    payoffs: GamePayoffs, logits: np.ndarray, beta, delta: float, max_iter: int
) -> MeanFieldResult:
    """The compiled engine; games whose valid variables are not a prefix are reordered first
    (stable, so the update order of the valid variables is kept) and scattered back. With a
    :class:`~swarmgames.game.potentials.PairSource`, the games are solved in chunks whose
    tables are computed just before (:data:`SOURCE_CHUNK_ELEMS`): the same results as one
    batch, since every game is solved alone. A source that ranks its games' variables
    (``PairSource.shared``) gives every game's table in rank order, once for every group of
    games that hold the same variables, and each game is solved on its group's table."""
    from swarmgames.game.meanfield_compiled import PARALLEL_MIN_GAMES, solve_batch

    mask = payoffs.mask
    b, k_vars, a = payoffs.shape
    n_valid = mask.sum(axis=1)
    prefix = bool((mask == (np.arange(k_vars) < n_valid[:, None])).all())
    order = np.argsort(~mask, axis=1, kind="stable")
    rows = np.arange(b)[:, None]
    if not prefix:
        logits = logits[rows, order]

    def reordered(w, games):
        if w is None or prefix:
            return w
        o = order[games]
        w = w[np.arange(o.shape[0])[:, None], o]
        return np.take_along_axis(w, o[:, None, None, :, None], axis=3)

    source = payoffs.pair_source
    same = shared_tables(source)
    step = max(PARALLEL_MIN_GAMES, SOURCE_CHUNK_ELEMS // max(1, (k_vars * a) ** 2))
    if source is None:
        parts = [(np.arange(b), reordered(payoffs.pair, slice(None)), None, None)]
    elif same is None:
        parts = (
            (g, reordered(source.table(g), g), None, None)
            for g in (np.arange(lo, min(b, lo + step)) for lo in range(0, b, step))
        )
    else:
        head, rank = same
        # Variable k of a (reordered) game is variable rank[b, order[b, k]] of its table.
        perm = rank if prefix else np.take_along_axis(rank, order, axis=1)
        parts = (
            (g, w, table, perm[g])
            for g, w, table in ranked_chunks(source, head, np.arange(b), step)
        )
    q = np.zeros((b, k_vars, a), dtype=logits.dtype)
    its = np.zeros(b, dtype=np.int64)
    kls = np.zeros(b, dtype=np.float64)
    for g, w, table, game_perm in parts:
        q[g], its[g], kls[g] = solve_batch(
            logits[g], w, n_valid[g], beta, delta, max_iter, table=table, perm=game_perm
        )
    if not prefix:
        back = np.empty_like(q)
        back[rows, order] = q
        q = back
    return MeanFieldResult(q, its, kls < delta, kls)


SOURCE_CHUNK_ELEMS = 4_000_000
"""Entries of the pairwise tables of one chunk of games computed from a ``PairSource``
(16 MB in float32): at least ``PARALLEL_MIN_GAMES`` games per chunk."""


def check_parameters(beta: float, delta: float, max_iter: int) -> None:
    """Validate the mean-field parameters (messages name the parameter, rule and value)."""
    if not (np.isfinite(beta) and beta > 0):
        raise ValueError(f"beta must be > 0 and finite (got {beta})")
    if not (np.isfinite(delta) and delta > 0):
        raise ValueError(f"delta must be > 0 and finite (got {delta})")
    if isinstance(max_iter, bool) or not isinstance(max_iter, (int, np.integer)) or max_iter < 1:
        raise ValueError(f"max_iter must be an integer >= 1 (got {max_iter})")


def mean_field(
    payoffs: GamePayoffs,
    beta: float,
    delta: float = 1e-6,
    max_iter: int = 200,
    *,
    engine: str = "auto",
) -> MeanFieldResult:
    """Solve every local game of ``payoffs`` by mean-field coordinate updates (Algorithm 1).

    Parameters
    ----------
    payoffs : GamePayoffs
        Weighted tables from :func:`~swarmgames.game.potentials.evaluate_payoffs`.
    beta : float
        Inverse temperature, > 0 (1/payoff units).
    delta : float
        KL stopping threshold, > 0 (nats).
    max_iter : int
        Maximum number of sweeps, >= 1.
    engine : {"auto", "compiled", "blas", "sequential"}
        ``"compiled"``: the Numba kernel (fastest; bit-identical whatever the batch, padding
        and threads). ``"blas"``: numpy, one BLAS matrix-vector product per game and variable;
        a game's result does not depend on the other games of the batch, but it may change in
        the last bits with the padded width K. ``"sequential"`` (about 5 times slower than
        ``"blas"``): numpy with fixed-order sums, bit-identical whatever the padding.
        ``"auto"`` (default): ``"compiled"`` when Numba is installed, else ``"blas"``. See the
        module docstring.

    Returns
    -------
    MeanFieldResult

    Raises
    ------
    ValueError
        beta <= 0, delta <= 0, max_iter < 1, an unknown engine, or a valid variable without
        a valid action.
    BackendUnavailableError
        ``engine="compiled"`` without Numba.
    """
    check_parameters(beta, delta, max_iter)
    engine = resolve_engine(engine)
    _check_empty_actions(payoffs)
    b, k_vars, a = payoffs.unary.shape
    dt = payoffs.unary.dtype
    beta_t = dt.type(beta)
    # β·U with -inf at invalid actions: the softmax gives them exactly 0.
    logits_all = np.where(payoffs.action_mask, beta_t * payoffs.unary, dt.type(-np.inf))
    if engine == "compiled":
        return _mean_field_compiled(payoffs, logits_all, beta_t, delta, max_iter)
    wide = _wide_games(payoffs)
    if wide.any() and not wide.all():  # solved apart: whether a game is wide is its own
        parts = [np.flatnonzero(~wide), np.flatnonzero(wide)]
        solved = [
            mean_field(payoffs.select(g), beta, delta, max_iter, engine=engine) for g in parts
        ]
        return _gathered(b, parts, solved)
    wide = bool(wide.any())
    sequential = engine == "sequential"
    w_all = payoffs.pair_table()
    var_mask = payoffs.mask[:, :, None]
    # A padded variable keeps action 0 finite so that its (unused) softmax stays finite; it is
    # zeroed on output.
    logits_all[:, :, 0] = np.where(payoffs.mask, logits_all[:, :, 0], 0.0)

    out_q = np.zeros((b, k_vars, a), dtype=dt)
    out_it = np.zeros(b, dtype=np.int64)
    out_conv = np.zeros(b, dtype=bool)
    out_kl = np.full(b, np.nan)

    # Working set: the rows still running. Stopped rows are written out, then compacted away
    # (see _compact); each game's arithmetic does not depend on its row in the set.
    rows = np.arange(b)
    logits, w = logits_all, w_all
    q = _softmax(logits.copy())
    running = np.ones(b, dtype=bool)
    owned = False  # whether logits and w are private copies that may be compacted in place
    fast = not sequential and w is not None
    sweep = _blas_sweep(w, q, logits, beta_t, wide) if fast else None
    for it in range(1, int(max_iter) + 1 if b else 0):
        q_old = q.copy()
        if fast:
            sweep()
        else:
            _sweep_loop(w, q, logits, beta_t, sequential, wide)
        kl = _kl(q_old, q)
        stop = running & ((kl < delta) | (it == max_iter))
        if not stop.any():
            continue
        idx = rows[stop]
        out_q[idx] = q[stop] * var_mask[idx]
        out_it[idx] = it
        out_conv[idx] = kl[stop] < delta
        out_kl[idx] = kl[stop]
        running &= ~stop
        n_run = int(running.sum())
        if n_run == 0:
            break
        if owned:
            rows, logits, q, w = _compact(running, rows, logits, q, w)
            running = np.ones(n_run, dtype=bool)
        elif n_run < _COPY_FRACTION * running.size:
            # The first compaction copies the running rows (the caller's tables are
            # read-only); later ones move rows within these copies.
            rows, logits, q = rows[running], logits[running], q[running]
            w = None if w is None else w[running]
            running = np.ones(n_run, dtype=bool)
            owned = True
        else:
            continue
        if fast:
            sweep = _blas_sweep(w, q, logits, beta_t, wide)
    return MeanFieldResult(out_q, out_it, out_conv, out_kl)


def _wide_games(payoffs: GamePayoffs) -> np.ndarray:
    """Which games sum wide (module docstring, "Wide sums"), (B,) bool."""
    b, _, a = payoffs.unary.shape
    if payoffs.unary.dtype != np.float32 or not payoffs.has_pair:
        return np.zeros(b, dtype=bool)
    return payoffs.mask.sum(axis=1) * a >= WIDE_SUM_MIN


def _gathered(b: int, parts, solved) -> MeanFieldResult:
    """One result for ``b`` games from the results ``solved`` of the games ``parts``."""
    first = solved[0]
    out = [np.zeros((b, *x.shape[1:]), x.dtype) for x in (first.marginals, first.iterations,
           first.converged, first.kl)]  # fmt: skip
    for games, res in zip(parts, solved, strict=True):
        for o, x in zip(out, (res.marginals, res.iterations, res.converged, res.kl), strict=True):
            o[games] = x
    return MeanFieldResult(*out)
