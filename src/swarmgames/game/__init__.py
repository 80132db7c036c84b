"""Game layer: stage graphical games, local game decomposition, virtual mean neighbours, the
mean-field solver of Algorithm 1, baselines, the best-response refinement and equilibrium
measurement (local, global and ex-post regret).

See ``docs/game.md`` for the guide and the contract with scenarios.
"""

from swarmgames.game.actions import ActionModel, DisplacementActions, action_mask_of
from swarmgames.game.baselines import best_response, exact_profiles, random_profiles
from swarmgames.game.batch import LocalGameBatch
from swarmgames.game.capabilities import (
    PairSourceCapabilities,
    PotentialCapabilities,
    SolverCapabilities,
    capabilities_of,
)
from swarmgames.game.checks import check_action_model, check_potentials
from swarmgames.game.colocated import colocated_groups, separate_colocated
from swarmgames.game.equal import CarriedGame, EqualGames, equal_games
from swarmgames.game.equilibrium import (
    OwnerPayoffs,
    deviation_gains,
    enumerate_payoffs,
    global_regret,
    local_regret,
    owner_regret,
    profile_measures,
    profile_payoff,
    pure_equilibria,
)
from swarmgames.game.expost import expost_games, expost_regret
from swarmgames.game.held import HeldPairs
from swarmgames.game.inertia import Inertia
from swarmgames.game.kept import KeptRows, RowTables
from swarmgames.game.local import (
    LocalView,
    LocalViews,
    Messages,
    broadcast,
    build_local_game,
    build_local_games,
    centralised_game,
    gather_views,
    local_games,
    receive,
)
from swarmgames.game.meanfield import MeanFieldResult, mean_field
from swarmgames.game.potentials import (
    FunctionPotentials,
    GamePayoffs,
    Potentials,
    TablePotentials,
    evaluate_payoffs,
)
from swarmgames.game.problem import StageProblem
from swarmgames.game.refine import Refinement, refine_profiles
from swarmgames.game.rows import StageRows, shared_rows
from swarmgames.game.solvers import (
    SOLVERS,
    BestResponseSolver,
    ExactSolver,
    GameSolution,
    MeanFieldSolver,
    RandomSolver,
    Solver,
    make_solver,
)
from swarmgames.game.stage import (
    StageSolution,
    evaluate_games,
    measure_expost,
    measure_stage,
    plan_stage,
    solve,
    stage_regret,
)
from swarmgames.game.virtual import (
    VIRTUAL_MEANS,
    neighbourhood_means,
    outside_means,
    reaches_outside,
    virtual_mode,
)

__all__ = [
    "SOLVERS",
    "VIRTUAL_MEANS",
    "ActionModel",
    "BestResponseSolver",
    "CarriedGame",
    "DisplacementActions",
    "EqualGames",
    "ExactSolver",
    "FunctionPotentials",
    "GamePayoffs",
    "GameSolution",
    "HeldPairs",
    "Inertia",
    "KeptRows",
    "LocalGameBatch",
    "LocalView",
    "LocalViews",
    "MeanFieldResult",
    "MeanFieldSolver",
    "Messages",
    "OwnerPayoffs",
    "PairSourceCapabilities",
    "PotentialCapabilities",
    "Potentials",
    "RandomSolver",
    "Refinement",
    "RowTables",
    "Solver",
    "SolverCapabilities",
    "StageProblem",
    "StageRows",
    "StageSolution",
    "TablePotentials",
    "action_mask_of",
    "best_response",
    "broadcast",
    "build_local_game",
    "build_local_games",
    "capabilities_of",
    "centralised_game",
    "check_action_model",
    "check_potentials",
    "colocated_groups",
    "deviation_gains",
    "enumerate_payoffs",
    "equal_games",
    "evaluate_games",
    "evaluate_payoffs",
    "exact_profiles",
    "expost_games",
    "expost_regret",
    "gather_views",
    "global_regret",
    "local_games",
    "local_regret",
    "make_solver",
    "mean_field",
    "measure_expost",
    "measure_stage",
    "neighbourhood_means",
    "outside_means",
    "owner_regret",
    "plan_stage",
    "profile_measures",
    "profile_payoff",
    "pure_equilibria",
    "random_profiles",
    "reaches_outside",
    "receive",
    "refine_profiles",
    "separate_colocated",
    "shared_rows",
    "solve",
    "stage_regret",
    "virtual_mode",
]
