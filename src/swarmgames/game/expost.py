"""Ex-post regret: what a robot could have gained, given where its neighbours actually went.

The global regret (:func:`~swarmgames.game.equilibrium.global_regret`) scores robot i's
deviations in its true local game with its neighbours at their *current* states, as the
stage game does: the unary of eq. 5 is computed against the others' current states, the
pairwise term of eq. 6 against their next states. All robots move at once, so what robot i
actually gets is its payoff against the states its neighbours *reached*. The **ex-post
regret** is robot i's regret in hindsight: its true local game (actual states, the true
N_i(h), no virtual means) in which every other member l sits at its actual next state
:math:`S_l^+` and has no choice left, robot i at its current state with all its actions,

.. math:: R_i^{post} = \\max_{a \\in \\mathcal{A}_i} M_i(a; S^+_{-i}) - M_i(x_i; S^+_{-i})
          \\;\\ge 0,

:math:`x_i` the action robot i took. When every neighbour stands still
(:math:`S_l^+ = S_l`), this game is the global regret's with each neighbour at its
realised action, and the two regrets are equal.

The game is built by :func:`expost_games` as a :class:`~swarmgames.game.batch.
LocalGameBatch` (every other member one variable with one valid action, action 0, whose
state and next state are :math:`S_l^+`), so any mission's potentials score it through the
ordinary pipeline (:func:`~swarmgames.game.potentials.evaluate_payoffs`), and only the
owner's rows are read (:func:`expost_regret`; with a
:class:`~swarmgames.game.potentials.PairSource` only ``at`` of the realised profile).

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, eqs. 1, 5, 6 and section II.C (the stage
   game and its Nash equilibrium).
"""

from __future__ import annotations

import numpy as np

from swarmgames.game.actions import ActionModel, action_mask_of
from swarmgames.game.batch import LocalGameBatch
from swarmgames.game.equilibrium import OwnerPayoffs, owner_regret
from swarmgames.game.local import LocalViews
from swarmgames.game.potentials import GamePayoffs

__all__ = ["expost_games", "expost_regret"]


def expost_games(
    views: LocalViews,
    next_states: np.ndarray,
    action_model: ActionModel,
    *,
    t: float = 0.0,
) -> LocalGameBatch:
    """The ex-post games of the owners of ``views``: each owner at its own state with all its
    actions, every other member at its actual next state with one action (action 0).

    Parameters
    ----------
    views : LocalViews
        The owners' true inboxes (``Messages.views(owners)`` of the actual states; column 0
        is the owner).
    next_states : ndarray, shape (N, D)
        The state every robot actually reached.
    action_model : ActionModel
    t : float, default 0.0
        The stage time in seconds (``LocalGameBatch.t``): that of the stage whose decisions
        are judged, so time-dependent potentials score them as the stage game did.

    Returns
    -------
    LocalGameBatch
        No virtual means; ``next_states[b, l, a]`` is the member's reached state for every
        ``a`` and only ``action_mask[b, l, 0]`` is true for ``l >= 1``.
    """
    nxt_all = np.asarray(next_states, dtype=float)
    mask = np.asarray(views.members) >= 0
    safe = np.maximum(np.asarray(views.members), 0)
    b, k = mask.shape
    a = int(action_model.n_actions)
    own = np.asarray(views.states, dtype=float)[:, :1]  # (B, 1, D)
    states = np.where(mask[:, :, None], nxt_all[safe], 0.0)
    states[:, 0] = own[:, 0]
    nxt = np.repeat(states[:, :, None, :], a, axis=2)
    own_next = np.asarray(action_model.apply(own), dtype=float)
    if own_next.shape != (b, 1, a, own.shape[2]):
        raise ValueError(
            f"action model apply() must return shape {(b, 1, a, own.shape[2])} "
            f"(got {own_next.shape})"
        )
    nxt[:, 0] = own_next[:, 0]
    amask = np.zeros((b, k, a), dtype=bool)
    amask[:, 1:, 0] = mask[:, 1:]
    amask[:, 0] = action_mask_of(action_model, own)[:, 0] & mask[:, :1]
    return LocalGameBatch(
        owner=views.owner,
        members=views.members,
        mask=mask,
        states=states,
        is_virtual=np.zeros((b, k), dtype=bool),
        next_states=nxt,
        action_mask=amask,
        t=t,
    )


def expost_regret(payoffs: GamePayoffs | OwnerPayoffs, actions) -> np.ndarray:
    """Ex-post regret of each owner of ex-post games (:func:`expost_games`).

    Parameters
    ----------
    payoffs : GamePayoffs or OwnerPayoffs
        The ex-post games' payoffs, or their owners' rows.
    actions : array_like of int, shape (N,)
        The action every robot took (only the owners' are read).

    Returns
    -------
    ndarray, shape (B,)
        :math:`\\max_a M_i(a; S^+_{-i}) - M_i(x_i; S^+_{-i}) \\ge 0`.
    """
    joint = np.asarray(actions)
    if joint.ndim != 1:
        raise ValueError(f"actions must have shape (N,) (got {joint.shape})")
    owner = np.asarray(payoffs.owner)
    if owner.size and (owner.min() < 0 or owner.max() >= joint.size):
        raise ValueError(f"actions has {joint.size} entries but the games' owners need more")
    profile = np.zeros(payoffs.mask.shape, dtype=np.int64)
    profile[:, 0] = joint[owner]
    return owner_regret(payoffs, profile)
