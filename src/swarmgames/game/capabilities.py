"""Declared capabilities of potentials, pair sources and solvers.

The engine has one required form of every plug-in (a potentials object's ``unary`` and
``pairwise``, a pair source's ``table``, ``at`` and ``select``) and cheaper or richer
optional forms. Which optional forms an object offers it *declares*, in the manner of
scikit-learn's estimator tags: a frozen dataclass of booleans that the engine reads once
where it needs it, instead of probing the object for methods deep in a hot path.

* :class:`PotentialCapabilities`: the attribute ``capabilities`` of every
  :class:`~swarmgames.game.potentials.Potentials`, read through :func:`capabilities_of`,
  the one place that validates it (a plug-in without a valid declaration is refused there
  with a message naming the object and the rule);
* :class:`PairSourceCapabilities`: the attribute ``capabilities`` of every
  :class:`~swarmgames.game.potentials.PairSource`, read through
  :func:`pair_source_capabilities`;
* :class:`SolverCapabilities`: what a solver does with given potentials
  (``solver.capabilities(potentials)``, computed once per stage).

Examples
--------
>>> import numpy as np
>>> from swarmgames.game import FunctionPotentials
>>> pot = FunctionPotentials(lambda s: -np.linalg.norm(s, axis=-1))
>>> capabilities_of(pot).pair_table
False
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

__all__ = [
    "PairSourceCapabilities",
    "PotentialCapabilities",
    "SolverCapabilities",
    "capabilities_of",
    "pair_source_capabilities",
]


@dataclass(frozen=True)
class PotentialCapabilities:
    """The optional forms a potentials object offers, each a promise of methods.

    Parameters
    ----------
    pair_table : bool, default False
        ``pair_table(batch, dtype) -> (B, K, A, K, A)`` or None: the symmetrised pairwise
        table ``φ_p(k, a, l, c) + φ_p(l, c, k, a)`` in the solver's layout and ``dtype``,
        a new array the engine may overwrite (None: no pairwise term in this batch).
    pair_source : bool, default False
        ``pair_source(batch, weights, dtype) -> PairSource`` or None: the weighted table
        computed on demand (:class:`~swarmgames.game.potentials.PairSource`), ``weights``
        (B,) each game's pairwise weight; and ``pair_on_demand(dtype) -> bool``, whether
        ``pair_source`` gives a source for tables of ``dtype``.
    owner_rows : bool, default False
        ``owner_unary(batch) -> (B, A)``, equal to ``unary(batch)[:, 0]`` bit for bit; and,
        where ``pair_table`` is declared too, ``owner_pair_table(batch, dtype) ->
        (B, A, K, A)`` or None, equal to ``pair_table(batch, dtype)[:, 0]`` bit for bit.
    held_sharing : bool, default False
        ``held_sharing_min(dtype) -> int | None``: the valid entries (variables × actions)
        of a game from which equal games of a batch share one held pairwise table of
        ``dtype`` (``PairSource.shared``), None when they do not in this dtype.
    neighbourhood : bool, default False
        ``neighbourhood(batch) -> (B, A)``: a term ψ of every game's owner (variable 0) over
        its neighbourhood as a whole, for each action of the owner, given the owner's next
        state and the other members' states as the batch holds them; it enters the owner's
        unary row as ``α_a ψ`` (:func:`~swarmgames.game.potentials.evaluate_payoffs`).
    memory : bool, default False
        ``stage_bytes(k, a, games, n) -> (unary, owner_unary, pairwise)``: the working
        memory, bytes, of evaluating one batch of ``games`` games of ``k`` variables and
        ``a`` actions in a swarm of ``n`` robots (:func:`~swarmgames.sim.memory.
        estimate_memory`).
    """

    pair_table: bool = False
    pair_source: bool = False
    owner_rows: bool = False
    held_sharing: bool = False
    neighbourhood: bool = False
    memory: bool = False


#: The methods each field of :class:`PotentialCapabilities` promises.
_PROMISED = {
    "pair_table": ("pair_table",),
    "pair_source": ("pair_source", "pair_on_demand"),
    "owner_rows": ("owner_unary",),
    "held_sharing": ("held_sharing_min",),
    "neighbourhood": ("neighbourhood",),
    "memory": ("stage_bytes",),
}


@dataclass(frozen=True)
class PairSourceCapabilities:
    """The optional methods a :class:`~swarmgames.game.potentials.PairSource` offers.

    Parameters
    ----------
    at_sums : bool, default False
        ``at_sums(profile) -> (sums, at_kl)``: ``at(profile).sum(axis=3)`` (B, K, A) and
        ``at(profile)[b, k, profile[b, k], l]`` (B, K, K), bit for bit.
    shared : bool, default False
        ``shared() -> (head, rank)`` or None and ``ranked_table(games)``: games that hold the
        same variables in another order share one ranked table.
    """

    at_sums: bool = False
    shared: bool = False


@dataclass(frozen=True)
class SolverCapabilities:
    """What a solver does with given potentials (``solver.capabilities(potentials)``).

    Parameters
    ----------
    pairs_on_demand : bool, default False
        The solver computes the pairwise tables per chunk of games (a pair source) instead
        of holding a batch's: the stage sizes its batches by the measurements' rows.
    held_sharing_min : int or None, default None
        The smallest game (valid variables × actions) from which the solver solves the equal
        games of a batch on one held pairwise table; None: every game has its own.
    samples_actions : bool, default False
        The owner's action is drawn from its marginal rather than its argmax.
    draws : bool, default False
        ``solve_payoffs`` draws from the Generator it is given (sampled actions, random
        profiles): a problem of several swarms then solves each swarm's games in batches of
        their own, with the swarm's own Generator.
    """

    pairs_on_demand: bool = False
    held_sharing_min: int | None = None
    samples_actions: bool = False
    draws: bool = False


def _declared(obj: Any, kind: type, what: str, promised: dict) -> Any:
    try:
        caps = obj.capabilities
    except AttributeError:
        caps = None
    if not isinstance(caps, kind):
        raise TypeError(
            f"{what} must declare capabilities: a {kind.__name__} attribute "
            f"(got {type(caps).__name__} on {type(obj).__name__})"
        )
    for f in fields(caps):
        value = getattr(caps, f.name)
        if not isinstance(value, bool):
            raise TypeError(
                f"{what} capabilities.{f.name} must be a bool (got {value!r} on "
                f"{type(obj).__name__})"
            )
        for method in promised[f.name] if value else ():
            if not callable(getattr(obj, method, None)):
                raise TypeError(
                    f"{what} declares capabilities.{f.name} = True, so it must have a "
                    f"callable {method} (missing on {type(obj).__name__})"
                )
    return caps


def capabilities_of(potentials: Any) -> PotentialCapabilities:
    """The declared :class:`PotentialCapabilities` of ``potentials``, validated.

    Raises
    ------
    TypeError
        ``potentials`` has no ``capabilities`` of type :class:`PotentialCapabilities`, a
        field is not a bool, or a declared form's method is missing.
    """
    return _declared(potentials, PotentialCapabilities, "potentials", _PROMISED)


def pair_source_capabilities(source: Any) -> PairSourceCapabilities:
    """The declared :class:`PairSourceCapabilities` of the pair source ``source``, validated
    (as :func:`capabilities_of`)."""
    promised = {"at_sums": ("at_sums",), "shared": ("shared", "ranked_table")}
    return _declared(source, PairSourceCapabilities, "pair source", promised)
