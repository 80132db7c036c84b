"""Communication layer: what each robot knows of its neighbourhood, and what that costs.

Between the network (who can reach whom) and the game (what each robot decides from), a
communication model delivers every robot's state message (:mod:`~swarmgames.comms.wire`):
``ideal`` (exact, instant, free) or ``routed`` (flooded hop by hop over the links that exist
now, with delay and loss, into belief tables). See ``docs/comms.md``.
"""

from swarmgames.comms.beliefs import BeliefInbox, BeliefTable
from swarmgames.comms.flooding import Delivery, flood
from swarmgames.comms.models import COMMS_MODELS, CommsStats, IdealComms, RoutedComms
from swarmgames.comms.wire import airtime_s, message_bytes

__all__ = [
    "COMMS_MODELS",
    "BeliefInbox",
    "BeliefTable",
    "CommsStats",
    "Delivery",
    "IdealComms",
    "RoutedComms",
    "airtime_s",
    "flood",
    "message_bytes",
]
