"""Every built-in provider passes the shipped conformance check; broken ones are caught."""

import numpy as np
import pytest

from swarmgames.network.baselines import DiskProvider, KnnProvider
from swarmgames.network.conformance import (
    ProviderConformanceError,
    check_provider,
    check_snapshot,
)
from swarmgames.network.factory import make_provider
from swarmgames.topology import TopologySnapshot


@pytest.mark.parametrize("backend", ["olsr", "oracle", "disk", "knn"])
@pytest.mark.parametrize("full_tables", [False, True])
def test_builtin_providers_conform(backend, full_tables):
    # knn has no notion of range: its isolated robot still has k neighbours.
    check_provider(
        make_provider(backend, 6, 0, knn_k=1, full_tables=full_tables),
        range_limited=backend != "knn",
    )


def test_isolated_robot_rule():
    with pytest.raises(ProviderConformanceError, match="isolated robot"):
        check_provider(KnnProvider(6, k=1))


class _NoTimeCheck(DiskProvider):
    def advance(self, to_time, positions):
        self._time = float(to_time)
        return self._snapshot(np.nan_to_num(np.asarray(positions, dtype=float)))


def test_broken_provider_is_caught():
    with pytest.raises(ProviderConformanceError, match="earlier time must raise"):
        check_provider(_NoTimeCheck(6))


def test_snapshot_rules():
    ok = TopologySnapshot(0.0, 3, [0, 1], [1, 0], [1, 1], [1, 0])
    check_snapshot(ok, 3, 0.0)
    with pytest.raises(ProviderConformanceError, match="n_robots=3, expected 4"):
        check_snapshot(ok, 4, 0.0)
    # A snapshot cannot even be built with a route to itself, out-of-range ids or hop counts
    # that would overflow (the boundary where any provider's tables enter the simulation).
    with pytest.raises(ValueError, match="route to itself"):
        TopologySnapshot(0.0, 3, [0], [0], [1])
    with pytest.raises(ProviderConformanceError, match="next hop must be a 1-hop neighbour"):
        check_snapshot(TopologySnapshot(0.0, 3, [0], [2], [2], [2]), 3, 0.0)
    with pytest.raises(ValueError, match="n_robots must be >= 3"):
        check_provider(DiskProvider(2), n_robots=2)
