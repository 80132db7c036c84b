"""Environments for multi-agent learning over any mission: E swarms stepped together as one
Gymnasium vector environment (:func:`vector_env`), its PettingZoo ``ParallelEnv`` special case
(:func:`parallel_env`, E = 1), and an adapter to stable-baselines3 (:mod:`swarmgames.env.sb3`,
the ``rl`` extra).

Needs the optional ``env`` extra (``pip install "swarmgames[env]"``: pettingzoo, gymnasium);
importing this package without them raises
:class:`~swarmgames.errors.BackendUnavailableError` with that command.
"""

try:
    from swarmgames.env.parallel import SwarmParallelEnv, parallel_env
    from swarmgames.env.vector import REWARDS, SwarmVectorEnv, vector_env
except ImportError as exc:  # pettingzoo or gymnasium missing
    from swarmgames.errors import BackendUnavailableError

    raise BackendUnavailableError(
        f"the PettingZoo environment needs pettingzoo and gymnasium ({exc.name} is missing): "
        'pip install "swarmgames[env]"'
    ) from None

__all__ = ["REWARDS", "SwarmParallelEnv", "SwarmVectorEnv", "parallel_env", "vector_env"]
