"""Equilibrium measurement: payoffs of pure profiles, regret, exact pure Nash equilibria.

A local game is a potential game: every player k of robot i's local game is scored by the
same M_i (eq. 1), and the terms of M_i that do not involve x_k do not change when k deviates.
So the gain of player k deviating alone from a pure profile x to action a is

    g_k(a; x) = U[k, a] − U[k, x_k] + Σ_{l≠k} (W[k, a, l, x_l] − W[k, x_k, l, x_l])

(U, W the weighted tables of :mod:`swarmgames.game.potentials`), and the **regret** of x is the
largest such gain, max_k max_a g_k(a; x) >= 0; x is a pure Nash equilibrium (NE) iff its regret
is 0.

The **global (stage-game) regret** of robot i at a realised joint action is its gain by
deviating alone in its payoff over its *true* neighbourhood with actual states, no virtual
means: the deviation gain of variable 0 in the game built by
``local_games(true_snapshot, h, states, model, virtual_mean=False)``, with every other
variable held at its robot's realised action.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, section II.C (NE of the stage game).
.. [2] D. Monderer and L. S. Shapley, "Potential Games", Games and Economic Behavior 14, 1996.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from swarmgames.arrays import freeze_fields
from swarmgames.game.batch import LocalGameBatch
from swarmgames.game.capabilities import PotentialCapabilities, capabilities_of
from swarmgames.game.potentials import (
    GamePayoffs,
    Potentials,
    evaluate_payoffs,
    neighbourhood_row,
    owner_row,
    pair_weights,
    weighted_owner_rows,
)

__all__ = [
    "OwnerPayoffs",
    "deviation_gains",
    "enumerate_payoffs",
    "global_regret",
    "local_regret",
    "owner_deviations",
    "owner_payoffs",
    "owner_regret",
    "profile_measures",
    "profile_payoff",
    "pure_equilibria",
]


def _check_profile(payoffs: GamePayoffs, profile) -> np.ndarray:
    b, k, a = payoffs.shape
    x = np.asarray(profile)
    if x.shape != (b, k):
        raise ValueError(f"profile must have shape {(b, k)} (got {x.shape})")
    x = np.where(payoffs.mask, x, 0).astype(np.int64)
    if np.any((x < 0) | (x >= a)):
        raise ValueError(f"profile actions must be in [0, {a}) on valid variables")
    ok = np.take_along_axis(payoffs.action_mask, x[:, :, None], axis=2)[:, :, 0]
    bad = payoffs.mask & ~ok
    if bad.any():
        gb, gk = (int(v) for v in np.argwhere(bad)[0])
        raise ValueError(
            f"profile action {int(x[gb, gk])} is not valid for variable {gk} "
            f"(robot {int(payoffs.members[gb, gk])}) of game {gb}"
        )
    return x


def _pair_sums(payoffs: GamePayoffs, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``Σ_l W[b, k, a, l, x_l]`` (B, K, A) and ``W[b, k, x_k, l, x_l]`` (B, K, K) at the
    pure profile ``x``: from the pair source's ``at_sums`` where it has one (equal bit for
    bit, without the B K² A rows), else summed and gathered from ``payoffs.pair_at(x)``."""
    source = payoffs.pair_source
    if source is not None and source.capabilities.at_sums:
        return source.at_sums(x)
    at_l = payoffs.pair_at(x)
    return at_l.sum(axis=3), _at_profile(at_l, x)


def _pairs_at(payoffs: GamePayoffs, x: np.ndarray) -> np.ndarray:
    """The second of :func:`_pair_sums` alone: ``W[b, k, x_k, l, x_l]``, (B, K, K)."""
    source = payoffs.pair_source
    if source is not None and source.capabilities.at_sums:
        return source.at_sums(x)[1]
    return _at_profile(payoffs.pair_at(x), x)


def _fields(payoffs: GamePayoffs, x: np.ndarray, sums: np.ndarray | None = None) -> np.ndarray:
    """E[M | X_k = a] with every other variable at x: (B, K, A), up to terms free of x_k
    (``sums``: the first of :func:`_pair_sums` when the caller has it)."""
    field = payoffs.unary.astype(np.float64)
    if payoffs.has_pair:
        field = field + (_pair_sums(payoffs, x)[0] if sums is None else sums)
    return field


def _gains(payoffs: GamePayoffs, x: np.ndarray, sums: np.ndarray | None = None) -> np.ndarray:
    field = _fields(payoffs, x, sums)
    best = np.where(payoffs.action_mask, field, -np.inf).max(axis=2)
    cur = np.take_along_axis(field, x[:, :, None], axis=2)[:, :, 0]
    return np.where(payoffs.mask, np.maximum(best - cur, 0.0), 0.0)


def _at_profile(at_l: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``at_l[b, k, x[b, k], l]``, (B, K, K) contiguous, from ``at_l`` (B, K, A, K) in either
    memory layout, by one flat gather along whichever axes are contiguous (a pair source's
    rows hold the last axis outermost): the same values either way."""
    b, k, a, n_l = at_l.shape
    games = np.arange(b, dtype=np.int64)
    if at_l.strides[3] > at_l.strides[1]:
        rows = np.ascontiguousarray(at_l.transpose(0, 3, 1, 2))  # (B, L, K, A): no copy
        at = (games[:, None] * n_l + np.arange(n_l))[:, :, None] * (k * a)
        by_l = np.take(rows.reshape(-1), at + (np.arange(k) * a + x)[:, None, :])
        return np.ascontiguousarray(by_l.transpose(0, 2, 1))
    at = ((games[:, None] * k + np.arange(k)) * a + x)[:, :, None] * n_l
    return np.take(np.ascontiguousarray(at_l).reshape(-1), at + np.arange(n_l))


def _payoff(payoffs: GamePayoffs, x: np.ndarray, players, at_kl: np.ndarray | None = None):
    unary = np.take_along_axis(payoffs.unary, x[:, :, None], axis=2)[:, :, 0]
    if players is not None:
        players = np.asarray(players, dtype=bool)
        unary = np.where(players, unary, 0.0)
    total = unary.sum(axis=1)
    if payoffs.has_pair:
        if at_kl is None:
            at_kl = _pairs_at(payoffs, x)  # (B, K, K)
        if players is not None:
            at_kl = np.where(players[:, :, None] | players[:, None, :], at_kl, 0.0)
        total = total + 0.5 * at_kl.sum(axis=(1, 2))
    return total


def deviation_gains(payoffs: GamePayoffs, profile) -> np.ndarray:
    """Largest gain of each player by deviating alone from the pure ``profile``.

    Parameters
    ----------
    payoffs : GamePayoffs
    profile : array_like of int, shape (B, K)
        One action per variable (ignored at padding; must be valid elsewhere).

    Returns
    -------
    ndarray, shape (B, K)
        ``max_a g_k(a; x) >= 0``; 0 at padding.
    """
    return _gains(payoffs, _check_profile(payoffs, profile))


def local_regret(payoffs: GamePayoffs, profile) -> np.ndarray:
    """Regret of ``profile`` in each local game: the largest gain of any player, (B,)."""
    return deviation_gains(payoffs, profile).max(axis=1)


@dataclass(frozen=True, eq=False)
class OwnerPayoffs:
    """What the global regret needs of a batch of true local games: the owner's rows.

    The owner's deviation gain reads only row 0 of the tables, so a stage keeps these for
    every batch until the joint action is known, ``1 / K`` of the pairwise table instead of
    the whole ``(B, K, A, K, A)``.

    Parameters
    ----------
    unary : ndarray, shape (B, A)
        ``GamePayoffs.unary[:, 0]``.
    pair : ndarray, shape (B, A, K, A) or None
        ``GamePayoffs.pair[:, 0]``.
    action_mask : ndarray of bool, shape (B, K, A)
    mask : ndarray of bool, shape (B, K)
    owner : ndarray of int32, shape (B,)
    members : ndarray of int32, shape (B, K)
    pair_source : PairSource, optional
        The games' pairwise source when they have no table (``GamePayoffs.pair_source``);
        the owner's pairwise terms are then computed at the joint action.
    """

    unary: np.ndarray
    pair: np.ndarray | None
    action_mask: np.ndarray
    mask: np.ndarray
    owner: np.ndarray
    members: np.ndarray
    pair_source: Any = None

    def __post_init__(self) -> None:
        freeze_fields(self)

    @classmethod
    def of(cls, payoffs: GamePayoffs) -> OwnerPayoffs:
        """The owner's rows of ``payoffs`` (copies: the full tables can be freed)."""
        pair = None if payoffs.pair is None else payoffs.pair[:, 0].copy()
        return cls(
            payoffs.unary[:, 0].copy(),
            pair,
            payoffs.action_mask,
            payoffs.mask,
            payoffs.owner,
            payoffs.members,
            payoffs.pair_source,
        )

    @property
    def shape(self) -> tuple[int, int, int]:
        """``(B, K, A)`` of the games."""
        return self.action_mask.shape  # type: ignore[return-value]

    def select(self, games) -> OwnerPayoffs:
        """The owners' rows of the games ``games`` (indices or a boolean mask over B)."""
        idx = np.arange(self.owner.shape[0])[games]
        return OwnerPayoffs(
            self.unary[idx],
            None if self.pair is None else self.pair[idx],
            self.action_mask[idx],
            self.mask[idx],
            self.owner[idx],
            self.members[idx],
            None if self.pair_source is None else self.pair_source.select(idx),
        )


def owner_deviations(batch: LocalGameBatch, joint_actions) -> LocalGameBatch:
    """``batch`` with every variable but the owner held at its robot's realised action: what
    :func:`global_regret` reads of a true local game, and no more.

    The owner's deviation gain reads the owner's unary row and its pairwise terms with the
    others at their realised actions (``W[b, 0, a, l, x_l]``); neither depends on which other
    actions the other variables have (potentials see the others' *states*, not their action
    sets: :class:`~swarmgames.game.potentials.Potentials`). So the payoffs of this batch give
    the same global regret as those of ``batch``, while the potentials evaluate one action per
    neighbour instead of A.

    Parameters
    ----------
    batch : LocalGameBatch
        True local games, variable 0 the owner.
    joint_actions : array_like of int, shape (N,)
        Every robot's realised action (valid in the games where it is a variable).

    Returns
    -------
    LocalGameBatch
        The same games at the same stage time ``t``, with the held action masks.
    """
    joint = np.asarray(joint_actions, dtype=np.int64)
    members = np.asarray(batch.members)
    amask = np.asarray(batch.action_mask)
    held = np.zeros_like(amask)
    b, k = np.nonzero(batch.mask)
    held[b, k, joint[members[b, k]]] = True
    held[:, 0] = amask[:, 0]  # the owner keeps every action it has
    return replace(batch, action_mask=held & amask)


class _PairOnly:
    """``potentials`` without their unary (zeros) and neighbourhood term: the pairwise part
    of an evaluation, in every pairwise form the potentials declare."""

    def __init__(self, potentials, caps: PotentialCapabilities) -> None:
        self.potentials = potentials
        self.capabilities = PotentialCapabilities(
            pair_table=caps.pair_table, pair_source=caps.pair_source
        )

    def unary(self, batch: LocalGameBatch) -> np.ndarray:
        return np.zeros(batch.action_mask.shape)

    def pairwise(self, batch: LocalGameBatch) -> np.ndarray | None:
        return self.potentials.pairwise(batch)

    def pair_table(self, batch: LocalGameBatch, dtype) -> np.ndarray | None:
        return self.potentials.pair_table(batch, dtype)

    def pair_source(self, batch: LocalGameBatch, weights, dtype):
        return self.potentials.pair_source(batch, weights, dtype)

    def pair_on_demand(self, dtype) -> bool:
        return self.potentials.pair_on_demand(dtype)


class _SourceOnly(_PairOnly):
    """``potentials`` without their unary and with only their pair source: an evaluation
    whose pairwise part is the source, or nothing (the owners' table rows are then asked
    for separately)."""

    def __init__(self, potentials, caps: PotentialCapabilities) -> None:
        super().__init__(potentials, caps)
        self.capabilities = PotentialCapabilities(pair_source=caps.pair_source)

    def pairwise(self, batch: LocalGameBatch) -> None:
        return None


def owner_payoffs(
    batch: LocalGameBatch,
    potentials: Potentials,
    alpha_a: float = 1.0,
    alpha_b: float = 0.001,
    *,
    dtype=np.float64,
    pair_weighting: str = "sum",
) -> OwnerPayoffs:
    """The owners' rows of ``evaluate_payoffs(batch, potentials, alpha_a, alpha_b, dtype,
    pair_weighting)``,
    equal to ``OwnerPayoffs.of`` of it bit for bit: what :func:`global_regret` reads.

    Potentials that declare ``owner_rows`` (``owner_unary(batch) -> (B, A)``, φ_u of
    variable 0 only, equal to ``unary(batch)[:, 0]``) are asked for the owners' unary alone
    (the coverage potentials then integrate one variable per game instead of K); others are
    evaluated whole. Those that declare ``pair_table`` too are asked for the owners'
    pairwise rows alone (``owner_pair_table(batch, dtype) -> (B, A, K, A)``, row 0 of
    ``pair_table``, or None) where they give no pair source for the batch (one row of the
    table instead of K). A declared neighbourhood term is added to the owners' unary as
    :func:`~swarmgames.game.potentials.evaluate_payoffs` adds it.

    Raises
    ------
    ValueError
        As :func:`~swarmgames.game.potentials.evaluate_payoffs`.
    """
    caps = capabilities_of(potentials)
    if not caps.owner_rows:
        whole = evaluate_payoffs(
            batch, potentials, alpha_a, alpha_b, dtype=dtype, pair_weighting=pair_weighting
        )
        return OwnerPayoffs.of(whole)
    kw = {"dtype": dtype, "pair_weighting": pair_weighting}
    rows = None
    if caps.pair_table and alpha_b > 0 and batch.pair_mask is None:
        # The pair source where the potentials give one, else the owners' table rows alone.
        pay = evaluate_payoffs(batch, _SourceOnly(potentials, caps), alpha_a, alpha_b, **kw)
        if pay.pair_source is None:
            dt = np.dtype(dtype)
            table = potentials.owner_pair_table(batch, dt)
            if table is not None:
                w = pair_weights(batch, alpha_b, pair_weighting)
                rows = OwnerPayoffs.of(pay)
                rows = replace(rows, pair=weighted_owner_rows(batch, table, w, dt))
    if rows is None:
        pay = evaluate_payoffs(batch, _PairOnly(potentials, caps), alpha_a, alpha_b, **kw)
        rows = OwnerPayoffs.of(pay)
    dt = np.dtype(dtype)
    owner_u = potentials.owner_unary(batch)
    unary = owner_row(owner_u, batch, "owner unary potential", alpha_a, dt)
    if caps.neighbourhood:
        unary += neighbourhood_row(batch, potentials, alpha_a, dt)
    return OwnerPayoffs(
        unary, rows.pair, rows.action_mask, rows.mask, rows.owner, rows.members, rows.pair_source
    )


def global_regret(true_payoffs: GamePayoffs | OwnerPayoffs, joint_actions) -> np.ndarray:
    """Stage-game regret of each owner at the realised joint action.

    Parameters
    ----------
    true_payoffs : GamePayoffs or OwnerPayoffs
        Payoffs of the games built with actual states and true neighbourhoods
        (``virtual_mean=False``), or their owners' rows; column 0 of each game is its owner.
    joint_actions : array_like of int, shape (N,)
        The action every robot took.

    Returns
    -------
    ndarray, shape (B,)
        Gain of each owner by deviating alone, all other robots' actions fixed (the same
        values from ``GamePayoffs`` and from its ``OwnerPayoffs``).
    """
    joint = np.asarray(joint_actions)
    if joint.ndim != 1:
        raise ValueError(f"joint_actions must have shape (N,) (got {joint.shape})")
    members = true_payoffs.members
    if members.size and members.max() >= joint.size:
        raise ValueError(
            f"joint_actions has {joint.size} entries but the games use robot {members.max()}"
        )
    if np.any(true_payoffs.members[:, 0] != true_payoffs.owner):
        raise ValueError("global_regret needs games whose variable 0 is the owner")
    profile = np.where(true_payoffs.mask, joint[np.maximum(members, 0)], 0)
    return owner_regret(true_payoffs, profile)


def owner_regret(payoffs: GamePayoffs | OwnerPayoffs, profile) -> np.ndarray:
    """Gain of each game's owner (variable 0) by deviating alone from the pure ``profile``.

    Parameters
    ----------
    payoffs : GamePayoffs or OwnerPayoffs
        The games, or their owners' rows.
    profile : array_like of int, shape (B, K)
        Every variable's action (ignored at padding; must be valid elsewhere).

    Returns
    -------
    ndarray, shape (B,)
        ``max_a g_0(a; x) >= 0``: column 0 of :func:`deviation_gains` (computed from the
        owner's rows only).
    """
    rows = OwnerPayoffs.of(payoffs) if isinstance(payoffs, GamePayoffs) else payoffs
    x = _check_profile(rows, profile)
    field = rows.unary.astype(np.float64)
    if rows.pair is not None:
        b, a, k = rows.pair.shape[:3]
        base = np.arange(b * a * k, dtype=np.int64).reshape(b, a, k) * rows.pair.shape[3]
        field = field + np.take(rows.pair.reshape(-1), base + x[:, None, :]).sum(axis=2)
    elif rows.pair_source is not None:  # W[b, 0, a, l, x_l], computed without the table
        field = field + rows.pair_source.at(x.astype(np.int64))[:, 0].sum(axis=2)
    amask = rows.action_mask[:, 0]
    best = np.where(amask, field, -np.inf).max(axis=1)
    cur = np.take_along_axis(field, x[:, :1], axis=1)[:, 0]
    return np.where(rows.mask[:, 0], np.maximum(best - cur, 0.0), 0.0)


def profile_payoff(payoffs: GamePayoffs, profile, players=None) -> np.ndarray:
    """M(x) of eq. 1 at the pure ``profile`` in each game, (B,).

    ``players`` (B, K) bool, optional: count only the unary terms of these variables and the
    pairs with at least one of them (a game with context variables, ``virtual_mean =
    "exact"``: the payoff of the deciding members, with their terms against the context but
    without the context's own constants)."""
    return _payoff(payoffs, _check_profile(payoffs, profile), players)


def profile_measures(payoffs: GamePayoffs, profile, players=None) -> tuple[np.ndarray, np.ndarray]:
    """:func:`profile_payoff` and :func:`local_regret` of the same ``profile`` from one
    evaluation of the pairwise rows at it (the costly part: B K² A entries, summed and read
    at the profile by the pair source's ``at_sums`` where it has one, else from
    ``payoffs.pair_at``), each equal to what the function alone returns.

    Returns
    -------
    payoff, regret : ndarray, shape (B,)
    """
    x = _check_profile(payoffs, profile)
    sums, at_kl = _pair_sums(payoffs, x) if payoffs.has_pair else (None, None)
    return _payoff(payoffs, x, players, at_kl), _gains(payoffs, x, sums).max(axis=1)


def enumerate_payoffs(
    payoffs: GamePayoffs, game: int, max_profiles: int = 1_000_000
) -> tuple[np.ndarray, list[np.ndarray]]:
    """M over every pure profile of one game, by enumeration.

    Parameters
    ----------
    payoffs : GamePayoffs
    game : int
        Index of the game in the batch.
    max_profiles : int
        Refuse games with more joint profiles than this.

    Returns
    -------
    grid : ndarray, shape (n_0, ..., n_{K_b - 1})
        M at every combination of valid actions of the game's K_b valid variables.
    actions : list of ndarray
        ``actions[k]``: the valid action indices of valid variable k (the grid's axis k).
    """
    valid_vars = np.flatnonzero(payoffs.mask[game])
    actions = [np.flatnonzero(payoffs.action_mask[game, k]) for k in valid_vars]
    sizes = [a.size for a in actions]
    n_prof = int(np.prod(sizes, dtype=np.float64))
    if n_prof > max_profiles:
        raise ValueError(
            f"game {game} (robot {int(payoffs.owner[game])}) has {n_prof} joint profiles, "
            f"more than max_profiles={max_profiles}"
        )
    nv = len(valid_vars)
    grid = np.zeros(sizes)
    for i, (k, acts) in enumerate(zip(valid_vars, actions, strict=True)):
        shape = [1] * nv
        shape[i] = acts.size
        grid = grid + payoffs.unary[game, k, acts].reshape(shape)
    if payoffs.has_pair:
        pair = payoffs.pair_table([game])[0]
        for i, j in itertools.combinations(range(nv), 2):
            vk, vl = valid_vars[i], valid_vars[j]
            block = pair[vk][np.ix_(actions[i], [vl], actions[j])][:, 0, :]
            shape = [1] * nv
            shape[i], shape[j] = sizes[i], sizes[j]
            grid = grid + block.reshape(shape)
    return grid, actions


def pure_equilibria(
    payoffs: GamePayoffs, game: int, *, tol: float = 1e-12, max_profiles: int = 1_000_000
) -> np.ndarray:
    """Every pure Nash equilibrium of one local game, by enumeration.

    A profile is a NE iff no single variable can raise M by more than ``tol`` (relative to the
    largest |M|) by changing its own action.

    Returns
    -------
    ndarray of int, shape (n_eq, K)
        Action indices in the batch's layout (0 at padding columns). Never empty: the maximum
        of M is always a NE of a potential game.
    """
    grid, actions = enumerate_payoffs(payoffs, game, max_profiles)
    k = payoffs.shape[1]
    valid_vars = np.flatnonzero(payoffs.mask[game])
    slack = tol * max(1.0, float(np.abs(grid).max(initial=0.0)))
    is_ne = np.ones(grid.shape, dtype=bool)
    for axis in range(grid.ndim):
        is_ne &= grid >= grid.max(axis=axis, keepdims=True) - slack
    idx = np.argwhere(is_ne)
    out = np.zeros((idx.shape[0], k), dtype=np.int64)
    for i, var in enumerate(valid_vars):
        out[:, var] = actions[i][idx[:, i]]
    return out
