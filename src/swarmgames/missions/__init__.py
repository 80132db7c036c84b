"""Missions: what the swarm is asked to do, as potentials of the stage game.

:class:`Mission` is the protocol the simulation needs; missions are found by name in a
registry (:func:`get_mission`) that other packages extend through the entry-point group
``swarmgames.missions``; :func:`check_mission` tells a plug-in author what is wrong. Built in:
``coverage`` (the paper's), ``rendezvous`` and ``flocking``, with the UAV motion models and
the swarm geometry shared by every mission. See ``docs/missions.md``.
"""

from swarmgames.missions.conformance import check_mission
from swarmgames.missions.coverage import CoveragePotentials, GaussianROI, SignalModel
from swarmgames.missions.flocking import FlockingMission
from swarmgames.missions.motion import (
    AccelerationActions,
    HeadingActions,
    TakeOff,
    arena_for,
    disc_states,
    uav_actions,
)
from swarmgames.missions.protocol import Mission
from swarmgames.missions.registry import (
    ENTRY_POINT_GROUP,
    MissionEntry,
    broken_plugins,
    get_mission,
    mission_names,
    register_mission,
    unregister_mission,
)
from swarmgames.missions.rendezvous import RendezvousMission

__all__ = [
    "ENTRY_POINT_GROUP",
    "AccelerationActions",
    "CoveragePotentials",
    "FlockingMission",
    "GaussianROI",
    "HeadingActions",
    "Mission",
    "MissionEntry",
    "RendezvousMission",
    "SignalModel",
    "TakeOff",
    "arena_for",
    "broken_plugins",
    "check_mission",
    "disc_states",
    "get_mission",
    "mission_names",
    "register_mission",
    "uav_actions",
    "unregister_mission",
]
