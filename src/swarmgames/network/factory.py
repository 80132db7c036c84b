"""Build a neighbourhood provider from a backend name and plain parameters."""

from __future__ import annotations

import numpy as np

from swarmgames.errors import BackendUnavailableError, ConfigError
from swarmgames.names import BACKENDS
from swarmgames.network.baselines import DiskProvider, KnnProvider
from swarmgames.network.olsr.provider import OlsrProvider
from swarmgames.network.oracle import OracleProvider
from swarmgames.network.parameters import OlsrParameters, RadioParameters
from swarmgames.network.provider import NeighbourhoodProvider

__all__ = ["BACKENDS", "make_provider"]


def make_provider(
    backend: str,
    n_robots: int,
    rng: int | np.random.Generator | None = None,
    *,
    hops: int = 2,
    radio: RadioParameters | None = None,
    olsr: OlsrParameters | None = None,
    disk_radius_m: float = 368.84,
    knn_k: int = 4,
    full_tables: bool = False,
    shadowing_key: int | None = None,
) -> NeighbourhoodProvider:
    """The provider named ``backend`` for ``n_robots`` robots.

    Parameters
    ----------
    backend : str
        One of :data:`BACKENDS`: ``'olsr'`` (built-in RFC 3626 model), ``'oracle'`` (instant
        shortest paths), ``'disk'`` (fixed radius), ``'knn'`` (k nearest), ``'ns3'`` (ns-3).
    n_robots : int
        Number of robots.
    rng : int, Generator or None
        Seed of the provider's random draws.
    hops : int, default 2
        Neighbourhood radius h the game needs, hops.
    radio : RadioParameters, optional
        Propagation and reception (olsr, oracle, ns3; default: ns-3 defaults).
    olsr : OlsrParameters, optional
        OLSR timing (olsr, ns3; default: ns-3 defaults).
    disk_radius_m : float, default 368.84
        Radius of the ``disk`` baseline, metres.
    knn_k : int, default 4
        Number of neighbours of the ``knn`` baseline.
    full_tables : bool, default False
        Keep every route, whatever its length (trace replay, Figure 1). Otherwise only what
        N_i(h) needs: the ``olsr`` backend follows ``olsr.hello_only`` (``'auto'``: HELLO-only
        when ``hops <= 2``, where TCs cannot change N_i(h)) and the ``oracle`` keeps routes of
        at most ``hops`` hops.
    shadowing_key : int, optional
        Key of the static per-pair shadowing field (olsr, oracle, ns3); backends given the same
        key see the same channel. Default: drawn from ``rng`` when shadowing is on.

    Raises
    ------
    ConfigError
        For an unknown backend name.
    BackendUnavailableError
        For ``'ns3'`` when ns-3 is not installed.

    Examples
    --------
    >>> make_provider("oracle", 3, 0).name
    'oracle'
    """
    olsr = OlsrParameters() if olsr is None else olsr
    if backend == "olsr":
        flag = olsr.hello_only
        hello_only = (hops <= 2 if flag == "auto" else bool(flag)) and not full_tables
        return OlsrProvider(n_robots, radio, olsr, hello_only, rng, shadowing_key=shadowing_key)
    if backend == "oracle":
        return OracleProvider(
            n_robots,
            radio,
            max_hops=None if full_tables else hops,
            seed=rng,
            shadowing_key=shadowing_key,
        )
    if backend == "disk":
        return DiskProvider(n_robots, disk_radius_m)
    if backend == "knn":
        return KnnProvider(n_robots, knn_k)
    if backend == "ns3":
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

        return Ns3Provider(n_robots, radio, olsr, rng, shadowing_key=shadowing_key)
    raise ConfigError(f"backend must be one of {', '.join(BACKENDS)} (got {backend!r})")
