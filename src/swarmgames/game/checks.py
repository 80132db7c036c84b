"""Conformance checks for user plug-ins: potentials and action models.

Run these once on a representative batch when writing a scenario (in the spirit of
PettingZoo's ``parallel_api_test`` and scikit-learn's ``check_estimator``). They raise
``ValueError`` with a message that says what is wrong; they return nothing on success.

What is checked
---------------
Potentials (:func:`check_potentials`):
  * ``unary`` / ``pairwise`` exist and return arrays of the documented shapes, or ``None``
    for ``pairwise``, with a real floating or integer dtype;
  * ``capabilities`` is a :class:`~swarmgames.game.capabilities.PotentialCapabilities`
    whose declared forms have their methods; a declared ``neighbourhood(batch)`` returns
    ``(B, A)`` real values, finite at the owners' valid actions;
  * values are finite at every valid entry (padding may hold anything);
  * **game independence**: evaluating a sub-batch gives the same rows as evaluating the whole
    batch. A potential that mixes games (a sum over the batch axis, a normalisation by a batch
    statistic) would make batched and one-by-one solving disagree.

Action models (:func:`check_action_model`):
  * ``n_actions >= 1``; ``apply`` returns ``(..., A, D)`` finite next states for any leading
    shape; ``valid`` (if any) returns ``(..., A)`` booleans with at least one valid action in
    every state.
"""

from __future__ import annotations

import numpy as np

from swarmgames.game.actions import ActionModel, action_mask_of
from swarmgames.game.batch import LocalGameBatch
from swarmgames.game.capabilities import capabilities_of
from swarmgames.game.potentials import Potentials, evaluate_payoffs

__all__ = ["check_action_model", "check_potentials"]


def check_potentials(potentials: Potentials, batch: LocalGameBatch) -> None:
    """Check that ``potentials`` follows the :class:`Potentials` contract on ``batch``.

    Parameters
    ----------
    potentials : Potentials
    batch : LocalGameBatch
        A representative batch with at least one game (two or more to test game independence).

    Raises
    ------
    ValueError
        The first problem found.
    """
    for name in ("unary", "pairwise"):
        if not callable(getattr(potentials, name, None)):
            raise ValueError(f"potentials must have a callable {name}(batch) method")
    try:
        caps = capabilities_of(potentials)
    except TypeError as exc:
        raise ValueError(str(exc)) from None
    # Shapes and finiteness (evaluate_payoffs checks them and names the entry).
    full = evaluate_payoffs(batch, potentials, 1.0, 1.0)
    outputs = {"unary": potentials.unary(batch), "pairwise": potentials.pairwise(batch)}
    if caps.neighbourhood:
        outputs["neighbourhood"] = potentials.neighbourhood(batch)
    for name, out in outputs.items():
        if out is None:
            continue
        arr = np.asarray(out)
        if not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
            raise ValueError(f"potentials.{name} must return real numbers (got dtype {arr.dtype})")
    if batch.n_games < 2:
        return
    half = np.arange(batch.n_games)[::2]
    part = evaluate_payoffs(batch.select(half), potentials, 1.0, 1.0)
    if not np.allclose(part.unary, full.unary[half], rtol=1e-9, atol=1e-12):
        which = "unary or neighbourhood" if caps.neighbourhood else "unary"
        raise ValueError(
            f"potentials.{which} of a game depends on the other games of the batch: a "
            "sub-batch gives different values (batched and one-by-one solving would disagree)"
        )
    part_w, full_w = part.pair_table(), full.pair_table(half)
    if (part_w is None) != (full_w is None) or (
        part_w is not None and not np.allclose(part_w, full_w, 1e-9, 1e-12)
    ):
        raise ValueError(
            "potentials.pairwise of a game depends on the other games of the batch: a "
            "sub-batch gives different values (batched and one-by-one solving would disagree)"
        )


def check_action_model(model: ActionModel, states) -> None:
    """Check that ``model`` follows the :class:`ActionModel` contract at ``states``.

    Parameters
    ----------
    model : ActionModel
    states : array_like, shape (N, D)
        Representative states (include ones at the edges of any bounds).

    Raises
    ------
    ValueError
        The first problem found.
    """
    states = np.asarray(states, dtype=float)
    if states.ndim != 2:
        raise ValueError(f"states must have shape (N, D) (got {states.shape})")
    n_actions = getattr(model, "n_actions", None)
    if not isinstance(n_actions, (int, np.integer)) or n_actions < 1:
        raise ValueError(f"action model n_actions must be an integer >= 1 (got {n_actions!r})")
    n, d = states.shape
    for shape in ((n, d), (1, n, d)):
        nxt = np.asarray(model.apply(states.reshape(shape)))
        want = (*shape[:-1], int(n_actions), d)
        if nxt.shape != want:
            raise ValueError(f"action model apply() must return shape {want} (got {nxt.shape})")
        if not np.all(np.isfinite(nxt)):
            raise ValueError("action model apply() returned non-finite next states")
    ok = action_mask_of(model, states)
    empty = ~ok.any(axis=-1)
    if empty.any():
        i = int(np.flatnonzero(empty)[0])
        raise ValueError(f"action model leaves state {i} ({states[i].tolist()}) no valid action")
