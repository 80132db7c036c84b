"""Environments for multi-agent learning: a PettingZoo ``ParallelEnv`` over any mission.

Needs the optional ``env`` extra (``pip install "swarmgames[env]"``: pettingzoo, gymnasium);
importing this package without them raises
:class:`~swarmgames.errors.BackendUnavailableError` with that command.
"""

try:
    from swarmgames.env.parallel import SwarmParallelEnv, parallel_env
except ImportError as exc:  # pettingzoo or gymnasium missing
    from swarmgames.errors import BackendUnavailableError

    raise BackendUnavailableError(
        f"the PettingZoo environment needs pettingzoo and gymnasium ({exc.name} is missing): "
        'pip install "swarmgames[env]"'
    ) from None

__all__ = ["SwarmParallelEnv", "parallel_env"]
