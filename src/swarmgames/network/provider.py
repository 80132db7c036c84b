"""The interface every neighbourhood provider (OLSR model, oracle, disk, knn, ns-3) implements,
and the snapshot of a provider's state that checkpoints and planners use."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

from swarmgames.topology import TopologySnapshot

__all__ = ["NeighbourhoodProvider", "NetworkState", "SnapshotUnsupported", "check_state"]


class SnapshotUnsupported(Exception):
    """A provider cannot snapshot its state (ns-3: the simulator has no snapshot); runs on it
    cannot be resumed and cannot be planned ahead by restoring it."""


@dataclass(frozen=True, eq=False)
class NetworkState:
    """Everything a provider needs to continue exactly where it was (opaque to callers).

    Returned by ``provider.state()`` and taken back by ``provider.restore(state)``. It is
    independent of the provider: advancing the provider after ``state()`` does not change
    it, and one state can be restored many times (a planner explores from it; a checkpoint
    stores it as data: arrays, numbers, strings and the provider's table classes).

    Attributes
    ----------
    provider : str
        The provider's ``name``.
    n_robots : int
    time : float
        The provider's time, seconds.
    rng : dict or None
        The bit-generator state of the provider's random draws (jitter, fading), if any.
    data : Any
        The provider's own part (for the OLSR model: a copy of every node's tables, queued
        messages and timers; ``None`` for providers that are a function of the positions).
    """

    provider: str
    n_robots: int
    time: float
    rng: dict | None = None
    data: Any = None


def check_state(provider: Any, state: NetworkState) -> None:
    """Raise ``ValueError`` unless ``state`` was taken from a provider like ``provider`` (the
    same ``name`` and number of robots)."""
    if not isinstance(state, NetworkState):
        raise TypeError(f"state must be a NetworkState (got {type(state).__name__})")
    if state.provider != provider.name or state.n_robots != provider.n_robots:
        raise ValueError(
            f"this state is of a {state.provider!r} network of {state.n_robots} robots; the "
            f"provider is {provider.name!r} with {provider.n_robots} robots"
        )


@runtime_checkable
class NeighbourhoodProvider(Protocol):
    """A source of routing-table snapshots for a moving swarm.

    A provider owns the time axis of the network: ``reset`` places the robots at time
    ``start_time`` and ``advance`` moves the network forward. Positions passed to ``advance``
    hold, piecewise constant, from the provider's current time until ``to_time`` (the convention
    of ``positions.csv`` traces: a row holds from its ``t`` until the node's next row).

    Providers may also offer ``state() -> NetworkState`` and ``restore(state)``: a snapshot of
    everything the provider will do next (tables, queued messages, timers, random state), so
    that restoring it and advancing with the same positions gives the same snapshots. The
    built-in providers do, except ns-3 (its ``state`` raises :class:`SnapshotUnsupported`).
    Runs need it to be resumed (``swarmgames run --resume``); a provider without it still
    runs, and its run folders are kept stage by stage but cannot be continued.
    """

    name: str

    @property
    def time(self) -> float:
        """Current simulated time, in seconds."""
        ...

    def reset(self, positions: np.ndarray, start_time: float = 0.0) -> TopologySnapshot:
        """Start a fresh network with robots at ``positions`` (shape (N, 3), metres)."""
        ...

    def advance(self, to_time: float, positions: np.ndarray) -> TopologySnapshot:
        """Run the network until ``to_time`` with robots held at ``positions`` and return every
        robot's routing-table view at ``to_time``."""
        ...
