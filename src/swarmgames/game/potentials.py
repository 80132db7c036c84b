"""Potentials of the factorised payoff (paper eq. 1) and their evaluation on a batch.

A scenario supplies a :class:`Potentials` object with two vectorised methods evaluated once per
batch of local games::

    unary(batch)    -> (B, K, A)           φ_u(S_k, x_k)
    pairwise(batch) -> (B, K, K, A, A)     φ_p(S_k, x_k, S_l, x_l), or None

The payoff of local game b at a pure profile x (eq. 1) is

    M_b(x) = α_a Σ_k φ_u(k, x_k) + α_b Σ_{k≠l} φ_p(k, x_k, l, x_l),

the pairwise sum running over ordered pairs of distinct valid variables (and, if the batch has
one, over ``pair_mask``). With ``pair_weighting = "mean"`` the pairwise weight of game b is
α_b / (K_b − 1) instead, K_b its number of valid variables (:func:`pair_weights`), so that a
variable's pairwise payoff is α_b times the mean of its terms with the others rather than their
sum: the pull of the pairwise term then stays the same whatever the size of the neighbourhood.
:func:`evaluate_payoffs` turns potentials into the two tables the solvers use
(:class:`GamePayoffs`): the weighted unary ``U = α_a φ_u`` and the symmetrised pairwise
``W[b, k, a, l, c] = w_b (φ_p(k, a, l, c) + φ_p(l, c, k, a))`` (``w_b`` = α_b or the mean
weight), so that

    M_b(x) = Σ_k U[k, x_k] + ½ Σ_{k≠l} W[k, x_k, l, x_l],
    E_{Q_-k}[M_b | x_k] = U[k, x_k] + Σ_{l≠k} Σ_c Q_l(c) W[k, x_k, l, c] + const.

Padding, invalid actions and masked pairs are set to exactly 0 in both tables; non-finite
values anywhere else are an error naming the robot, variable and action.

Potentials that declare a neighbourhood term (``capabilities.neighbourhood``) add to the
owner's unary row a term ψ of the owner (variable 0) over its neighbourhood as a whole,

    U[b, 0, a] += α_a ψ(b, a),

given the owner's next state after action a and the other members' states as the batch
holds them (their reported states in the solved game, the actual ones in the true game of
the global regret, the reached ones in the ex-post games). The solvers see it as a unary
term of the owner: the other members' actions do not enter it (the mean-field solver sees
it in the owner's field only), so an objective such as "keep at least one neighbour within
range" is scored against where the others are, not where they will go.

A potential whose pairwise term is cheap to compute from the states may instead hand the
engine a :class:`PairSource` (the optional ``pair_source`` method): W is then computed per
game where it is used (inside the compiled mean-field kernel's chunks, and at the profiles
the measurements need), and the ``(B, K, A, K, A)`` table of the batch is never held.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, eq. 1 (factorised payoff).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar, Protocol, runtime_checkable

import numpy as np

from swarmgames.arrays import freeze_fields
from swarmgames.errors import PayoffError
from swarmgames.game.batch import LocalGameBatch
from swarmgames.game.capabilities import (
    PairSourceCapabilities,
    PotentialCapabilities,
    capabilities_of,
    pair_source_capabilities,
)
from swarmgames.names import PAIR_WEIGHTINGS

__all__ = [
    "FunctionPotentials",
    "GamePayoffs",
    "PairSource",
    "Potentials",
    "TablePotentials",
    "evaluate_payoffs",
    "neighbourhood_row",
    "owner_row",
    "pair_weights",
    "ranked_chunks",
    "shared_tables",
    "weighted_pair_table",
]


@runtime_checkable
class Potentials(Protocol):
    """User-supplied potentials of eq. 1, vectorised over a whole :class:`LocalGameBatch`.

    ``unary(batch)`` returns ``(B, K, A)``: φ_u for every variable and action. It may depend on
    the *states* (not the actions) of the other variables of the same game (the coverage unary,
    eq. 5, does). ``pairwise(batch)`` returns ``(B, K, K, A, A)`` with
    ``[b, k, l, a, c] = φ_p(S_k, a, S_l, c)``, or ``None`` when there is no pairwise term. Values
    at padding, invalid actions and ``k == l`` are ignored (they may be anything, even NaN).
    Potentials that depend on time (a moving target) read the stage time ``batch.t`` in
    seconds; the states carry no clock.

    ``capabilities`` (:class:`~swarmgames.game.capabilities.PotentialCapabilities`) declares
    which of the optional forms below the object offers; the engine reads the declaration
    (:func:`~swarmgames.game.capabilities.capabilities_of`), never probes for methods.

    Optional cheaper form (``pair_table``): ``pair_table(batch, dtype) -> (B, K, A, K, A)``
    returning the symmetrised table ``φ_p(k, a, l, c) + φ_p(l, c, k, a)`` directly in the
    solver's layout (in ``dtype``), as a new array that the engine may overwrite, or
    ``None`` when there is no pairwise term. When declared (and the batch has no
    ``pair_mask``), :func:`evaluate_payoffs` uses it instead of
    ``pairwise``: no ``(B, K, K, A, A)`` table, no transposed copies, half the peak memory.

    Optional on-demand form (``pair_source``), tried first: ``pair_source(batch, weights,
    dtype) -> PairSource`` (or ``None`` to fall back to the forms above), the weighted table W
    computed per game where it is needed (:class:`PairSource`), with ``weights`` the
    pairwise weight of every game, shape ``(B,)`` (:func:`pair_weights`); the built-in
    coverage potentials offer it for float32 tables. With it, ``pair_on_demand(dtype) ->
    bool`` says beforehand whether ``pair_source`` gives a source for ``dtype``: a stage
    solved by the compiled engine then sizes its batches without the tables' budget
    (:func:`~swarmgames.game.stage.size_groups`), so that games holding the same robots
    fall in one batch and share their tables (``PairSource.shared``).

    Optional owner-only forms (``owner_rows``): ``owner_unary(batch) -> (B, A)``, φ_u of
    every game's variable 0 alone, equal to ``unary(batch)[:, 0]`` bit for bit, and
    ``owner_pair_table(batch, dtype) -> (B, A, K, A)`` (or ``None``), equal to
    ``pair_table(batch, dtype)[:, 0]`` bit for bit; the global and ex-post regret, which
    read only the owners' rows, use them
    (:func:`~swarmgames.game.equilibrium.owner_payoffs`).

    Optional neighbourhood term (``neighbourhood``): ``neighbourhood(batch) -> (B, A)``, a
    term ψ of every game's owner (variable 0) over its neighbourhood as a whole, for every
    action of the owner, given its next state and the other members' states as the batch
    holds them; :func:`evaluate_payoffs` adds ``α_a ψ`` to the owner's unary row. It lets a
    mission score what is not a sum over pairs ("keep at least one neighbour in range").
    """

    capabilities: PotentialCapabilities

    def unary(self, batch: LocalGameBatch) -> np.ndarray: ...

    def pairwise(self, batch: LocalGameBatch) -> np.ndarray | None: ...


@runtime_checkable
class PairSource(Protocol):
    """The weighted, symmetrised pairwise table W of a batch, computed on demand.

    ``W[b, k, a, l, c] = w_b (φ_p(k, a, l, c) + φ_p(l, c, k, a))``, ``w_b`` game b's pairwise
    weight (:func:`pair_weights`: α_b unless the games are weighted by their size), in the
    layout and with the
    zeros of :attr:`GamePayoffs.pair` (0 unless ``(k, l)`` is a pair of distinct valid
    variables and both actions are valid), finite, in the payoffs' dtype. Every game's values
    depend on that game only, and every method returns the same values for it.

    ``table(games)`` returns ``W[games]``, shape ``(len(games), K, A, K, A)``, a new array;
    ``at(profile)`` returns ``W[b, k, a, l, profile[b, l]]`` for every game, shape
    ``(B, K, A, K)`` (what the payoff and regret measurements need, without the table);
    ``select(games)`` returns the source of a subset of games.

    ``capabilities`` (:class:`~swarmgames.game.capabilities.PairSourceCapabilities`)
    declares the optional methods below.

    Optional (``at_sums``): ``at_sums(profile) -> (sums, at_kl)``,
    ``at(profile).sum(axis=3)`` (B, K, A) and ``at(profile)[b, k, profile[b, k], l]``
    (B, K, K), equal to them bit for bit without holding :meth:`at`'s B K² A rows: the
    payoff and regret measurements use it
    (:func:`~swarmgames.game.equilibrium.profile_measures`).

    Optional, together (``shared``): ``shared() -> (head, rank)`` (or None) and
    ``ranked_table(games)``, for batches in which games hold the same variables in another
    order (a dense swarm, where every game holds every robot). ``rank`` (B, K) int ranks
    every game's variables canonically (a permutation of ``0 .. K-1``, the valid variables first);
    ``ranked_table(games)`` returns ``W[games]`` with the variables in rank order,
    ``T[g, rank[b, k], a, rank[b, l], c] = W[b, k, a, l, c]`` for ``b = games[g]`` (the
    engines only read it, so it may be a view of a table the source holds); ``head``
    (B,) int names for every game one whose ranked table equals its own bit for bit
    (``head[head[b]] == head[b]``). The compiled mean-field engine then computes the heads'
    ranked tables only and sums every game's pair fields in rank order
    (:mod:`~swarmgames.game.meanfield_compiled`, "Shared tables"): a game's results do not
    depend on which games share its table.
    """

    capabilities: PairSourceCapabilities

    def table(self, games: np.ndarray) -> np.ndarray: ...

    def at(self, profile: np.ndarray) -> np.ndarray: ...

    def select(self, games) -> PairSource: ...


def shared_tables(source) -> tuple[np.ndarray, np.ndarray] | None:
    """``source.shared()``, ``(head, rank)`` as int64 arrays, when ``source`` is a
    :class:`PairSource` that ranks its games' variables (declared ``shared``), else None
    (also for ``source`` None)."""
    same = source.shared() if source is not None and source.capabilities.shared else None
    if same is None:
        return None
    head, rank = same
    return np.asarray(head, dtype=np.int64), np.asarray(rank, dtype=np.int64)


def ranked_chunks(source, head: np.ndarray, games: np.ndarray, per: int):
    """The ranked tables of the groups of ``games`` (game indices; ``head`` from
    :func:`shared_tables`), ``per`` groups at a time: yields ``(sel, tables, table)``, the
    positions in ``games`` of a chunk's games, their groups' ranked tables
    (``source.ranked_table``) and the table of each of them (an index into ``tables``)."""
    heads, table_of = np.unique(head[games], return_inverse=True)
    table_of = table_of.reshape(-1)
    for lo in range(0, heads.size, per):
        sel = np.flatnonzero((table_of >= lo) & (table_of < lo + per))
        yield sel, source.ranked_table(heads[lo : lo + per]), table_of[sel] - lo


@dataclass(frozen=True)
class FunctionPotentials:
    """Potentials from element-wise callables of next states.

    Parameters
    ----------
    unary_fn : callable ``(s_next (..., D)) -> (...)``
        φ_u of a variable given its next state; broadcast over ``batch.next_states``.
    pairwise_fn : callable ``(s_k (..., D), s_l (..., D)) -> (...)``, optional
        φ_p of two variables given their next states; broadcast over all ``(k, l, a, c)``.

    Examples
    --------
    >>> import numpy as np
    >>> pot = FunctionPotentials(lambda s: -np.linalg.norm(s, axis=-1))
    >>> pot.pairwise(None) is None
    True
    """

    unary_fn: Callable[[np.ndarray], np.ndarray]
    pairwise_fn: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None

    #: No optional form.
    capabilities: ClassVar[PotentialCapabilities] = PotentialCapabilities()

    def unary(self, batch: LocalGameBatch) -> np.ndarray:
        """φ_u at every next state, ``(B, K, A)``."""
        return np.asarray(self.unary_fn(batch.next_states))

    def pairwise(self, batch: LocalGameBatch) -> np.ndarray | None:
        """φ_p for every pair of variables and actions, ``(B, K, K, A, A)``."""
        if self.pairwise_fn is None:
            return None
        nxt = batch.next_states
        s_k = nxt[:, :, None, :, None, :]
        s_l = nxt[:, None, :, None, :, :]
        return np.asarray(self.pairwise_fn(s_k, s_l))


@dataclass(frozen=True, eq=False)
class TablePotentials:
    """Potentials given as explicit tables (random test games, precomputed payoffs).

    Parameters
    ----------
    unary_table : ndarray, shape (B, K, A)
    pairwise_table : ndarray, shape (B, K, K, A, A), optional

    Notes
    -----
    The tables belong to one batch: pair a sub-batch ``batch.select(g)`` with
    ``potentials.select(g)``.
    """

    unary_table: np.ndarray
    pairwise_table: np.ndarray | None = None

    #: No optional form.
    capabilities: ClassVar[PotentialCapabilities] = PotentialCapabilities()

    def unary(self, batch: LocalGameBatch) -> np.ndarray:
        """The unary table."""
        return np.asarray(self.unary_table)

    def pairwise(self, batch: LocalGameBatch) -> np.ndarray | None:
        """The pairwise table, or None."""
        return None if self.pairwise_table is None else np.asarray(self.pairwise_table)

    def select(self, games) -> TablePotentials:
        """The tables of a subset of games (to pair with ``LocalGameBatch.select``)."""
        pair = None if self.pairwise_table is None else np.asarray(self.pairwise_table)[games]
        return TablePotentials(np.asarray(self.unary_table)[games], pair)


@dataclass(frozen=True, eq=False)
class GamePayoffs:
    """Weighted payoff tables of a batch, ready for the solvers.

    Parameters
    ----------
    unary : ndarray, shape (B, K, A)
        ``α_a φ_u``; 0 at padding and invalid actions.
    pair : ndarray, shape (B, K, A, K, A) or None
        ``α_b (φ_p(k, a, l, c) + φ_p(l, c, k, a))``; 0 unless ``(k, l)`` is a valid pair and
        both actions are valid. ``None`` when there is no pairwise term (or α_b = 0).
    action_mask : ndarray of bool, shape (B, K, A)
    mask : ndarray of bool, shape (B, K)
    owner : ndarray of int32, shape (B,)
    members : ndarray of int32, shape (B, K)
    pair_source : PairSource or None
        W computed on demand instead of held in ``pair`` (then ``pair`` is None). Read W
        through :attr:`has_pair`, :meth:`pair_table` and :meth:`pair_at`, which serve both.
    """

    unary: np.ndarray
    pair: np.ndarray | None
    action_mask: np.ndarray
    mask: np.ndarray
    owner: np.ndarray
    members: np.ndarray
    pair_source: PairSource | None = None

    def __post_init__(self) -> None:
        freeze_fields(self)

    @property
    def shape(self) -> tuple[int, int, int]:
        """``(B, K, A)``."""
        return self.unary.shape  # type: ignore[return-value]

    @property
    def has_pair(self) -> bool:
        """Whether there is a pairwise term (held or on demand)."""
        return self.pair is not None or self.pair_source is not None

    def pair_table(self, games=None) -> np.ndarray | None:
        """W of ``games`` (all by default), ``(G, K, A, K, A)``; None without pairwise term.
        Held tables are returned as they are (read-only), on-demand ones computed."""
        if self.pair_source is not None:
            idx = np.arange(self.shape[0]) if games is None else np.arange(self.shape[0])[games]
            return self.pair_source.table(idx)
        if self.pair is None or games is None:
            return self.pair
        return self.pair[games]

    def pair_at(self, profile: np.ndarray) -> np.ndarray:
        """``W[b, k, a, l, profile[b, l]]``, shape (B, K, A, K) (a pairwise term needed)."""
        if self.pair_source is not None:
            return self.pair_source.at(np.asarray(profile, dtype=np.int64))
        b, k, a = self.pair.shape[:3]
        base = np.arange(b * k * a * k, dtype=np.int64).reshape(b, k, a, k) * self.pair.shape[4]
        flat = base + profile[:, None, None, :]
        return np.take(self.pair.reshape(-1), flat)

    def select(self, games) -> GamePayoffs:
        """The payoffs of a subset of games."""
        return GamePayoffs(
            self.unary[games],
            None if self.pair is None else self.pair[games],
            self.action_mask[games],
            self.mask[games],
            self.owner[games],
            self.members[games],
            None if self.pair_source is None else self.pair_source.select(games),
        )


def _where(batch: LocalGameBatch, b: int, k: int) -> str:
    owner = int(batch.owner[b])
    member = int(batch.members[b, k])
    return f"local game of robot {owner} (game {b}), variable {k} (robot {member})"


def _check_empty_actions(batch: LocalGameBatch | GamePayoffs) -> None:
    """Every valid variable needs a valid action (else its marginal is undefined)."""
    empty = batch.mask & ~batch.action_mask.any(axis=2)
    if empty.any():
        b, k = (int(v) for v in np.argwhere(empty)[0])
        raise ValueError(f"action set is empty for {_where(batch, b, k)}")


def pair_weights(batch: LocalGameBatch, alpha_b: float, weighting: str = "sum") -> np.ndarray:
    """The pairwise weight of every game of ``batch``, shape ``(B,)`` float64.

    .. math:: w_b = \\alpha_b \\ (\\text{sum}), \\qquad
        w_b = \\frac{\\alpha_b}{\\max(K_b - 1, 1)} \\ (\\text{mean}),

    with :math:`K_b` the number of valid variables of game b (virtual and context robots
    included). Eq. 1 sums the pairwise term over every pair of a local game, so a variable's
    pairwise payoff grows with the size of its neighbourhood while its unary does not;
    ``"mean"`` makes it α_b times the mean over its partners. Every pair of a game has the same
    weight, so the game stays a potential game (best response still ends at a pure Nash
    equilibrium).

    Parameters
    ----------
    batch : LocalGameBatch
    alpha_b : float
        >= 0.
    weighting : {"sum", "mean"}
        :data:`~swarmgames.names.PAIR_WEIGHTINGS`.

    Raises
    ------
    ValueError
        An unknown ``weighting``, or ``"mean"`` on a batch with a ``pair_mask`` (whose
        variables do not all pair with each other, so no single per-game mean exists).

    Examples
    --------
    >>> import numpy as np
    >>> from swarmgames.game.batch import LocalGameBatch
    >>> mask = np.array([[True, True, True], [True, False, False]])
    >>> batch = LocalGameBatch(
    ...     owner=np.array([0, 1]), members=np.where(mask, [[0, 1, 2], [1, 0, 0]], -1),
    ...     mask=mask, states=np.zeros((2, 3, 2)), is_virtual=np.zeros((2, 3), bool),
    ...     next_states=np.zeros((2, 3, 1, 2)), action_mask=mask[..., None])
    >>> pair_weights(batch, 0.001, "mean").tolist()
    [0.0005, 0.001]
    """
    if weighting not in PAIR_WEIGHTINGS:
        raise ValueError(
            f"pair_weighting must be one of {', '.join(map(repr, PAIR_WEIGHTINGS))} "
            f"(got {weighting!r})"
        )
    if weighting == "sum":
        return np.full(batch.n_games, float(alpha_b))
    if batch.pair_mask is not None:
        raise ValueError(
            "pair_weighting 'mean' needs games whose variables all pair with each other "
            "(this batch has a pair_mask, as the centralised game does)"
        )
    others = np.maximum(np.count_nonzero(batch.mask, axis=1) - 1, 1)
    return float(alpha_b) / others


def evaluate_payoffs(
    batch: LocalGameBatch,
    potentials: Potentials,
    alpha_a: float = 1.0,
    alpha_b: float = 0.001,
    *,
    dtype=np.float64,
    pair_weighting: str = "sum",
) -> GamePayoffs:
    """Evaluate ``potentials`` on ``batch`` and build the weighted tables of eq. 1.

    Parameters
    ----------
    batch : LocalGameBatch
    potentials : Potentials
    alpha_a, alpha_b : float
        Weights of the unary and pairwise terms, >= 0 (paper: 1 and 0.001).
    dtype : numpy dtype
        float64 (default) or float32; float32 halves the memory of the pairwise table, which is
        ``B K² A²`` values (648 MB in float64 for B = 10 000, K = 10, A = 9).
    pair_weighting : {"sum", "mean"}
        ``"sum"`` (eq. 1): every pair weighs α_b; ``"mean"``: α_b / (K_b − 1) in a game of
        K_b variables (:func:`pair_weights`).

    Returns
    -------
    GamePayoffs

    Raises
    ------
    ValueError
        Wrong shapes, an empty action set, negative weights, or a non-finite potential at a
        valid entry (the message names the robot, the variable and the action).
    """
    for name, val in (("alpha_a", alpha_a), ("alpha_b", alpha_b)):
        if not (np.isfinite(val) and val >= 0):
            raise ValueError(f"{name} must be >= 0 and finite (got {val})")
    dtype = np.dtype(dtype)
    if dtype not in (np.dtype(np.float64), np.dtype(np.float32)):
        raise ValueError(f"dtype must be float64 or float32 (got {dtype})")
    caps = capabilities_of(potentials)
    _check_empty_actions(batch)
    b, k, a = batch.n_games, batch.n_vars, batch.n_actions
    amask = batch.action_mask
    weights = pair_weights(batch, alpha_b, pair_weighting)

    u = np.asarray(potentials.unary(batch))
    if u.shape != (b, k, a):
        raise ValueError(f"unary potentials must have shape {(b, k, a)} (got {u.shape})")
    bad = amask & ~np.isfinite(u)
    if bad.any():
        gb, gk, ga = (int(v) for v in np.argwhere(bad)[0])
        raise PayoffError(
            f"unary potential is not finite ({u[gb, gk, ga]}) for {_where(batch, gb, gk)}, "
            f"action {ga}"
        )
    unary = np.where(amask, u, 0.0).astype(dtype, copy=False)
    unary = unary * dtype.type(alpha_a)
    if caps.neighbourhood:
        unary[:, 0] += neighbourhood_row(batch, potentials, alpha_a, dtype)

    pair = source = None
    if alpha_b > 0 and caps.pair_source and batch.pair_mask is None:
        source = potentials.pair_source(batch, weights, dtype)
        if source is not None:
            pair_source_capabilities(source)
    if source is not None:
        p = None
    elif alpha_b > 0 and caps.pair_table and batch.pair_mask is None:
        pair = weighted_pair_table(batch, potentials.pair_table, weights, dtype)
        p = None
    else:
        p = potentials.pairwise(batch) if alpha_b > 0 else None
    if p is not None:
        p = np.asarray(p)
        if p.shape != (b, k, k, a, a):
            raise ValueError(
                f"pairwise potentials must have shape {(b, k, k, a, a)} (got {p.shape})"
            )
        valid = (
            batch.valid_pairs()[:, :, :, None, None]
            & amask[:, :, None, :, None]
            & amask[:, None, :, None, :]
        )
        _check_pair_finite(batch, p, valid, layout="bklac")
        # W[b, k, a, l, c] = φ_p(k, a, l, c) + φ_p(l, c, k, a), in the solver's layout.
        # Entries outside ``valid`` never enter (they may be NaN), even for an asymmetric
        # pair_mask where only one of (k, l), (l, k) counts.
        pair = np.zeros((b, k, a, k, a), dtype=dtype)
        np.copyto(pair, p.transpose(0, 1, 3, 2, 4), where=valid.transpose(0, 1, 3, 2, 4))
        np.add(
            pair,
            p.transpose(0, 2, 4, 1, 3),
            out=pair,
            where=valid.transpose(0, 2, 4, 1, 3),
            casting="unsafe",
        )
        pair *= weights.astype(dtype)[:, None, None, None, None]
    return GamePayoffs(
        unary=unary,
        pair=pair,
        action_mask=np.asarray(amask),
        mask=np.asarray(batch.mask),
        owner=np.asarray(batch.owner),
        members=np.asarray(batch.members),
        pair_source=source,
    )


def owner_row(values, batch: LocalGameBatch, what: str, weight: float, dtype) -> np.ndarray:
    """``weight × values``, a term of every game's owner (variable 0) for each of its actions,
    shape (B, A) in ``dtype``, 0 at the owner's invalid actions (values there are ignored).

    Raises
    ------
    ValueError
        ``values`` not of shape (B, A), or not real numbers (``what`` names the term).
    PayoffError
        A value not finite at a valid action of an owner (the message names the robot and
        the action).
    """
    dtype = np.dtype(dtype)
    amask = np.asarray(batch.action_mask)[:, 0]
    values = np.asarray(values)
    if values.shape != amask.shape:
        raise ValueError(f"{what} must have shape {amask.shape} (got {values.shape})")
    if not (np.issubdtype(values.dtype, np.floating) or np.issubdtype(values.dtype, np.integer)):
        raise ValueError(f"{what} must be real numbers (got dtype {values.dtype})")
    bad = amask & ~np.isfinite(values)
    if bad.any():
        gb, ga = (int(v) for v in np.argwhere(bad)[0])
        raise PayoffError(
            f"{what} is not finite ({values[gb, ga]}) for {_where(batch, gb, 0)}, action {ga}"
        )
    return np.where(amask, values, 0.0).astype(dtype, copy=False) * dtype.type(weight)


def neighbourhood_row(
    batch: LocalGameBatch, potentials: Potentials, alpha_a: float, dtype
) -> np.ndarray:
    """``α_a ψ`` of the potentials' declared ``neighbourhood(batch)``, shape (B, A) in
    ``dtype``, 0 at the owner's invalid actions (:func:`owner_row`): what
    :func:`evaluate_payoffs` adds to the owner's unary row (and
    :func:`~swarmgames.game.equilibrium.owner_payoffs` to the owners' rows alike)."""
    psi = potentials.neighbourhood(batch)
    return owner_row(psi, batch, "neighbourhood term", alpha_a, dtype)


def _check_pair_finite(
    batch: LocalGameBatch, table: np.ndarray, valid: np.ndarray, layout: str
) -> None:
    """Raise naming the first valid non-finite pairwise entry; ``layout`` spells the axes of
    ``table`` with b (game), k and l (variables), a and c (their actions)."""
    bad = valid & ~np.isfinite(table)
    if bad.any():
        idx = tuple(int(v) for v in np.argwhere(bad)[0])
        at = dict(zip(layout, idx, strict=True))
        gb, gk, gl = at["b"], at["k"], at["l"]
        raise PayoffError(
            f"pairwise potential is not finite ({table[idx]}) for "
            f"{_where(batch, gb, gk)}, action {at['a']}, with variable {gl} "
            f"(robot {int(batch.members[gb, gl])}), action {at['c']}"
        )


def weighted_owner_rows(batch: LocalGameBatch, rows, weights, dtype) -> np.ndarray:
    """Row 0 of :func:`weighted_pair_table`, bit for bit, from ``rows``, row 0 of the
    table (``pair_table(batch, dtype)[:, 0]``, shape ``(B, A, K, A)``): each entry is scaled
    alike (in place when ``rows`` is the caller's own C-contiguous array of ``dtype``)."""
    b, k, a = batch.n_games, batch.n_vars, batch.n_actions
    w = np.asarray(rows)
    if w.shape != (b, a, k, a):
        raise ValueError(f"owner_pair_table must have shape {(b, a, k, a)} (got {w.shape})")
    amask = batch.action_mask
    vp = batch.valid_pairs()[:, 0]
    own = w.dtype == dtype and w.flags.writeable and w.flags.c_contiguous
    if own and np.isfinite(np.add.reduce(w, axis=None)):
        per_game = weights[:, None, None, None]
        w *= np.where(vp[:, None, :, None] & amask[:, 0, :, None, None], per_game, 0.0).astype(
            dtype
        )
        w *= amask[:, None, :, :]
        return w
    valid = vp[:, None, :, None] & amask[:, 0, :, None, None] & amask[:, None, :, :]
    _check_pair_finite(batch, w[:, None], valid[:, None], layout="bkalc")
    pair = np.zeros((b, a, k, a), dtype=dtype)
    per_game = weights.astype(dtype)[:, None, None, None]
    np.multiply(w, per_game, out=pair, where=valid, casting="unsafe")
    return pair


def weighted_pair_table(batch: LocalGameBatch, table_fn, weights, dtype) -> np.ndarray | None:
    """The table ``table_fn(batch, dtype)`` returns, already symmetrised and in the solver's
    layout ``(B, K, A, K, A)``, times each game's weight ``weights`` (B,); 0 outside the
    valid entries (what :func:`evaluate_payoffs` makes of potentials' ``pair_table``; in
    place when the table is the caller's own C-contiguous array of ``dtype``)."""
    b, k, a = batch.n_games, batch.n_vars, batch.n_actions
    w = table_fn(batch, dtype)
    if w is None:  # no pairwise term in this batch
        return None
    w = np.asarray(w)
    if w.shape != (b, k, a, k, a):
        raise ValueError(f"pair_table must have shape {(b, k, a, k, a)} (got {w.shape})")
    amask = batch.action_mask
    vp = batch.valid_pairs()
    own = w.dtype == dtype and w.flags.writeable and w.flags.c_contiguous
    if own and np.isfinite(np.add.reduce(w, axis=None)):
        # All finite (a non-finite entry anywhere makes the sum non-finite): scale in place
        # by α_b times the validity of (k, a, l) and then of c, with no 5-D mask.
        per_game = weights[:, None, None, None, None]
        w *= np.where(vp[:, :, None, :, None] & amask[:, :, :, None, None], per_game, 0.0).astype(
            dtype
        )
        w *= amask[:, None, None, :, :]
        return w
    valid = vp[:, :, None, :, None] & amask[:, :, :, None, None] & amask[:, None, None, :, :]
    _check_pair_finite(batch, w, valid, layout="bkalc")
    pair = np.zeros((b, k, a, k, a), dtype=dtype)
    per_game = weights.astype(dtype)[:, None, None, None, None]
    np.multiply(w, per_game, out=pair, where=valid, casting="unsafe")
    return pair
