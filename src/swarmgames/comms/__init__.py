"""Communication layer: what each robot knows of its neighbourhood, and what that costs.

Between the network (who can reach whom) and the game (what each robot decides from), a
communication model delivers every robot's state message (:mod:`~swarmgames.comms.wire`):
``ideal`` (exact, instant, free), ``routed`` (flooded hop by hop over the links that exist
now, with delay and loss, into belief tables), ``csma`` (the same flooding over one shared
802.11a channel: carrier sense, backoff, collisions and airtime) or ``ns3`` (the same
flooding as UDP packets in the ns-3 simulator). See ``docs/comms.md``.
"""

from swarmgames.comms.beliefs import BeliefInbox, BeliefTable
from swarmgames.comms.csma import CsmaComms
from swarmgames.comms.flooding import Delivery, flood
from swarmgames.comms.models import COMMS_MODELS, CommsStats, IdealComms, RoutedComms
from swarmgames.comms.ns3_comms import Ns3Comms
from swarmgames.comms.wire import airtime_s, decode_messages, encode_messages, message_bytes

__all__ = [
    "COMMS_MODELS",
    "BeliefInbox",
    "BeliefTable",
    "CommsStats",
    "CsmaComms",
    "Delivery",
    "IdealComms",
    "Ns3Comms",
    "RoutedComms",
    "airtime_s",
    "decode_messages",
    "encode_messages",
    "flood",
    "message_bytes",
]
