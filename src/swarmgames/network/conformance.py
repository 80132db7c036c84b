"""Conformance check for neighbourhood providers (for plug-ins such as an ns-3 backend).

``check_provider`` drives a provider through a short scripted scenario and raises a
:class:`ProviderConformanceError` naming the first rule of the
:class:`~swarmgames.network.provider.NeighbourhoodProvider` contract that it breaks (PettingZoo's
``parallel_api_test`` idea).

Checked:

* ``name`` is a non-empty string; ``reset`` returns a snapshot at ``start_time`` and sets
  ``time``; ``advance`` returns a snapshot at ``to_time`` and moves ``time``;
* snapshots have ``n_robots`` robots, entries sorted by ``(owner, dest)``, no ``owner == dest``,
  hop counts >= 1, read-only arrays, and a next hop that is ``-1`` or a 1-hop neighbour of the
  owner;
* moving backwards in time raises ``ValueError``; NaN positions raise ``ValueError``;
* a robot far from every other robot has no routes once the tables settle (30 s), for
  providers with a radio range (``range_limited``; not the ``knn`` baseline);
* a provider with ``state()``/``restore()``: restoring a state and advancing as before gives
  the same snapshots, twice (a state is not consumed); ``SnapshotUnsupported`` from
  ``state()`` is accepted (the provider says it cannot snapshot).
"""

from __future__ import annotations

import numpy as np

from swarmgames.topology import TopologySnapshot

__all__ = ["ProviderConformanceError", "check_provider", "check_snapshot"]


class ProviderConformanceError(Exception):
    """A provider does not follow the NeighbourhoodProvider contract."""


def _fail(msg: str) -> None:
    raise ProviderConformanceError(msg)


def check_snapshot(snap: TopologySnapshot, n_robots: int, time: float) -> None:
    """Check one snapshot's invariants (see module docstring)."""
    if not isinstance(snap, TopologySnapshot):
        _fail(f"expected a TopologySnapshot (got {type(snap).__name__})")
    if snap.n_robots != n_robots:
        _fail(f"snapshot has n_robots={snap.n_robots}, expected {n_robots}")
    if not np.isclose(snap.time, time):
        _fail(f"snapshot time is {snap.time}, expected {time}")
    key = snap.owner.astype(np.int64) * n_robots + snap.dest
    if key.size and (np.diff(key) <= 0).any():
        _fail("entries must be unique and sorted by (owner, dest)")
    if (snap.owner == snap.dest).any():
        _fail("a robot's table must not hold a route to itself")
    if snap.n_entries and (snap.hops.min() < 1):
        _fail(f"hop counts must be >= 1 (got {int(snap.hops.min())})")
    for name in ("owner", "dest", "hops", "next_hop"):
        if getattr(snap, name).flags.writeable:
            _fail(f"snapshot array {name} must be read-only")
    has_next = snap.next_hop >= 0
    if has_next.any():
        one = snap.hops == 1
        one_hop = set((snap.owner[one].astype(np.int64) * n_robots + snap.dest[one]).tolist())
        pairs = snap.owner[has_next].astype(np.int64) * n_robots + snap.next_hop[has_next]
        if not set(pairs.tolist()) <= one_hop:
            _fail("every next hop must be a 1-hop neighbour of the table's owner")


def check_provider(provider, n_robots: int = 6, range_limited: bool = True) -> None:
    """Run the conformance scenario on a freshly built ``provider`` for ``n_robots`` (>= 3)
    robots. ``range_limited=False`` skips the isolated-robot rule (for range-free baselines).

    Raises
    ------
    ProviderConformanceError
        Naming the first broken rule.

    Examples
    --------
    >>> from swarmgames.network.oracle import OracleProvider
    >>> check_provider(OracleProvider(6))
    """
    if n_robots < 3:
        raise ValueError(f"n_robots must be >= 3 (got {n_robots})")
    name = getattr(provider, "name", None)
    if not isinstance(name, str) or not name:
        _fail(f"provider.name must be a non-empty string (got {name!r})")
    # A line at 200 m (within the 368.84 m default range) and one robot 10 km away.
    pos = np.c_[np.arange(n_robots) * 200.0, np.zeros(n_robots), np.zeros(n_robots)]
    pos[-1] = [10_000.0, 10_000.0, 0.0]
    snap = provider.reset(pos, 1.0)
    if not np.isclose(provider.time, 1.0):
        _fail(f"reset(start_time=1.0) must set time to 1.0 (got {provider.time})")
    check_snapshot(snap, n_robots, 1.0)
    for t in (3.0, 10.5, 31.0):
        snap = provider.advance(t, pos)
        if not np.isclose(provider.time, t):
            _fail(f"advance({t}) must set time to {t} (got {provider.time})")
        check_snapshot(snap, n_robots, t)
    isolated = n_robots - 1
    if range_limited and ((snap.owner == isolated).any() or (snap.dest == isolated).any()):
        _fail("an isolated robot must have no routes after settling")
    if not (snap.owner == 0).any():
        _fail("robot 0 must have a route to its neighbour at 200 m after settling")
    try:
        provider.advance(2.0, pos)
    except ValueError:
        pass
    else:
        _fail("advance to an earlier time must raise ValueError")
    _check_state(provider, pos)
    bad = pos.copy()
    bad[0, 0] = np.nan
    try:
        provider.advance(40.0, bad)
    except ValueError:
        pass
    else:
        _fail("NaN positions must raise ValueError")


def _tables(snap: TopologySnapshot) -> tuple:
    return tuple(getattr(snap, k).tolist() for k in ("owner", "dest", "hops", "next_hop"))


def _check_state(provider, pos: np.ndarray) -> None:
    """The state rule of the module docstring (from the provider's current time)."""
    from swarmgames.network.provider import SnapshotUnsupported

    if getattr(provider, "state", None) is None:
        return
    if getattr(provider, "restore", None) is None:
        _fail("a provider with state() must have restore(state) too")
    try:
        saved = provider.state()
    except SnapshotUnsupported:
        return
    t0 = provider.time
    moved = pos.copy()
    moved[1] = [-10_000.0, 10_000.0, 0.0]  # robot 1 leaves for 8 s (longer than hold times)
    steps = ((8.0, moved), (20.0, pos))
    first = [_tables(provider.advance(t0 + dt, p)) for dt, p in steps]
    for attempt in (1, 2):
        provider.restore(saved)
        if not np.isclose(provider.time, t0):
            _fail(f"restore(state) must set time back to {t0} (got {provider.time})")
        again = [_tables(provider.advance(t0 + dt, p)) for dt, p in steps]
        if again != first:
            _fail(f"advancing after restore(state) (attempt {attempt}) gave other tables")
