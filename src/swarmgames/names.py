"""The names of the built-in backends, solvers, refinements, engines and controllers, kept in
one place.

The layers that implement them (:mod:`swarmgames.network.factory`,
:mod:`swarmgames.game.solvers`, :mod:`swarmgames.game.meanfield`) and the configuration
schema that accepts them (:mod:`swarmgames.config.schema`, whose ``Literal`` types are built
from these tuples) all read them here, so the lists cannot drift apart and importing the
schema does not load the layers.
"""

from __future__ import annotations

__all__ = [
    "BACKENDS",
    "COMMS_MODELS",
    "CONTROLLERS",
    "ENGINES",
    "GAME_SOLVERS",
    "PAIR_WEIGHTINGS",
    "REFINE_METHODS",
    "SOLVERS",
    "VIRTUAL_MEANS",
]

#: Network providers (``network.backend``).
BACKENDS = ("olsr", "oracle", "disk", "knn", "ns3")

#: The simulation's own controllers (``sim.controller``); the other values it accepts are the
#: baselines a mission declares, which may not take these names.
CONTROLLERS = ("game", "mpc")

#: Local-game solvers (:func:`swarmgames.game.solvers.make_solver`).
SOLVERS = ("mean_field", "exact", "best_response", "random")

#: What ``game.solver`` accepts: the solvers, and the centralised baseline (the mean-field
#: solver on one swarm-wide game).
GAME_SOLVERS = (*SOLVERS, "centralised")

#: Refinements of a solved local game's profile (``game.refine``,
#: :mod:`swarmgames.game.refine`).
REFINE_METHODS = ("none", "best_response")

#: How a local game weights its pairwise terms (``game.pair_weighting``): ``sum`` gives every
#: pair the weight α_b (eq. 1), ``mean`` gives it α_b / (K_b − 1) in a game of K_b robots.
PAIR_WEIGHTINGS = ("sum", "mean")

#: Mean-field engines (``game.engine``).
ENGINES = ("auto", "compiled", "blas", "sequential")

#: Communication models (``comms.model``).
COMMS_MODELS = ("ideal", "routed", "csma", "ns3")

#: How a local game stands in for the members' neighbours outside it (``game.virtual_mean``):
#: ``eq3`` the paper's virtual mean over N_j, ``outside`` the mean over N_j − N_i only,
#: ``exact`` the outside robots themselves as fixed context, ``off`` nothing.
VIRTUAL_MEANS = ("eq3", "outside", "exact", "off")
