"""The configuration boundary of the network layer: a provider from a :class:`NetworkConfig`.

The network layer takes plain parameters (:mod:`swarmgames.network.parameters`); this module
turns the validated configuration into them, once, and builds the provider with
:func:`~swarmgames.network.factory.make_provider`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from swarmgames.config import NetworkConfig
from swarmgames.network.factory import make_provider
from swarmgames.network.parameters import OlsrParameters, RadioParameters
from swarmgames.network.provider import NeighbourhoodProvider

__all__ = ["provider_from_config"]


def provider_from_config(
    network: NetworkConfig,
    n_robots: int,
    rng: int | np.random.Generator | None = None,
    **kwargs: Any,
) -> NeighbourhoodProvider:
    """The provider that ``network`` describes, for ``n_robots`` robots.

    Parameters
    ----------
    network : NetworkConfig
        Backend name, neighbourhood radius and the radio, OLSR and baseline settings.
    n_robots : int
        Number of robots.
    rng : int, Generator or None
        Seed of the provider's random draws.
    **kwargs
        Passed on to :func:`~swarmgames.network.factory.make_provider` (``full_tables``,
        ``shadowing_key``); an unknown name raises ``TypeError``.

    Returns
    -------
    NeighbourhoodProvider

    Examples
    --------
    >>> provider_from_config(NetworkConfig(backend="disk"), 5).radius
    368.84
    """
    return make_provider(
        network.backend,
        n_robots,
        rng,
        hops=network.hops,
        radio=RadioParameters(**network.radio.model_dump()),
        olsr=OlsrParameters(**network.olsr.model_dump()),
        disk_radius_m=network.disk_radius_m,
        knn_k=network.knn_k,
        **kwargs,
    )
