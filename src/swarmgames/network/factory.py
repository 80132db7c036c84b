"""Build a neighbourhood provider from a :class:`~swarmgames.config.NetworkConfig`."""

from __future__ import annotations

import numpy as np

from swarmgames.config import NetworkConfig
from swarmgames.errors import BackendUnavailableError, ConfigError
from swarmgames.network.baselines import DiskProvider, KnnProvider
from swarmgames.network.olsr.provider import OlsrProvider
from swarmgames.network.oracle import OracleProvider
from swarmgames.network.provider import NeighbourhoodProvider

__all__ = ["BACKENDS", "make_provider"]

#: Names accepted by :func:`make_provider`.
BACKENDS = ("olsr", "oracle", "disk", "knn", "ns3")


def make_provider(
    config: NetworkConfig | None,
    n_nodes: int,
    seed: int | np.random.Generator | None = None,
    full_tables: bool = False,
    shadowing_key: int | None = None,
) -> NeighbourhoodProvider:
    """The provider named by ``config.backend`` for ``n_nodes`` robots.

    Parameters
    ----------
    config : NetworkConfig or None
        Backend name and its parameters (default configuration if None).
    n_nodes : int
        Number of robots.
    seed : int, Generator or None
        Seed of the provider's random draws.
    full_tables : bool, default False
        Keep every route, whatever its length (trace replay, Figure 1). Otherwise only what
        N_i(h) needs: the ``olsr`` backend follows ``config.olsr.hello_only`` (``'auto'``:
        HELLO-only when ``config.hops <= 2``, where TCs cannot change N_i(h)) and the
        ``oracle`` keeps routes of at most ``config.hops`` hops.
    shadowing_key : int, optional
        Key of the static per-pair shadowing field (olsr, oracle, ns3); backends given the same
        key see the same channel. Default: drawn from ``seed`` when shadowing is on.

    Raises
    ------
    ConfigError
        For an unknown backend name.
    BackendUnavailableError
        For ``'ns3'`` when ns-3 is not installed.
    """
    config = config or NetworkConfig()
    name = config.backend
    if name == "olsr":
        flag = config.olsr.hello_only
        hello_only = (config.hops <= 2 if flag == "auto" else bool(flag)) and not full_tables
        return OlsrProvider(
            n_nodes, config.radio, config.olsr, hello_only, seed, shadowing_key=shadowing_key
        )
    if name == "oracle":
        return OracleProvider(
            n_nodes,
            config.radio,
            max_hops=None if full_tables else config.hops,
            seed=seed,
            shadowing_key=shadowing_key,
        )
    if name == "disk":
        return DiskProvider(n_nodes, config.disk_radius_m)
    if name == "knn":
        return KnnProvider(n_nodes, config.knn_k)
    if name == "ns3":
        # Provided by the optional ns-3 backend; imported lazily so the core never needs ns-3.
        try:
            from swarmgames.network.ns3_backend import (  # type: ignore[import-not-found]
                Ns3Provider,
            )
        except ModuleNotFoundError as exc:
            if exc.name != "swarmgames.network.ns3_backend":
                raise
            raise BackendUnavailableError(
                "the 'ns3' backend is not part of this installation of swarmgames"
            ) from None

        return Ns3Provider(config, n_nodes, seed, shadowing_key=shadowing_key)
    raise ConfigError(f"network.backend must be one of {', '.join(BACKENDS)} (got {name!r})")
