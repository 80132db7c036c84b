"""The configuration boundary of the network and communication layers: a provider from a
:class:`NetworkConfig`, a communication model from a :class:`CommsConfig`.

The lower layers take plain parameters (:mod:`swarmgames.network.parameters`); this module
turns the validated configuration into them, once, and builds the provider with
:func:`~swarmgames.network.factory.make_provider` and the model of :mod:`swarmgames.comms`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from swarmgames.comms import IdealComms, RoutedComms
from swarmgames.comms.csma import CsmaComms
from swarmgames.comms.ns3_comms import Ns3Comms
from swarmgames.config import NetworkConfig
from swarmgames.errors import ConfigError
from swarmgames.network.factory import make_provider
from swarmgames.network.ns3_backend import Ns3Provider
from swarmgames.network.parameters import OlsrParameters, RadioParameters
from swarmgames.network.propagation import PropagationModel
from swarmgames.network.provider import NeighbourhoodProvider

__all__ = ["comms_from_config", "provider_from_config"]


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


def comms_from_config(
    config, state_dim: int, provider: Any = None
) -> IdealComms | RoutedComms | Ns3Comms:
    """The communication model of a :class:`~swarmgames.config.ScenarioConfig`.

    Parameters
    ----------
    config : ScenarioConfig
        Uses ``comms``, ``network.hops``, ``network.radio``, ``swarm.n_robots`` and
        ``game.virtual_mean`` (``"exact"`` delivers every robot's context, to 2h hops).
    state_dim : int
        D, the number of state columns of the mission.
    provider : NeighbourhoodProvider, optional
        The run's network; a routed model uses its radio channel (``provider.model``, with
        its static shadowing draws) so that the links messages travel are the provider's;
        the ns3 model sends its packets between the provider's ns-3 nodes.

    Raises
    ------
    ConfigError
        ``comms.model = 'ns3'`` with a provider that is not an ns-3 one (a user's provider
        passed to :func:`swarmgames.run`).
    """
    c, net = config.comms, config.network
    beliefs = {
        "decide_after_s": c.decide_after_s,
        "max_age_s": c.max_age_s,
        "dead_reckoning": c.dead_reckoning,
        "gps_error_m": config.faults.gps_error_m,
        "context": config.game.virtual_mean == "exact",
    }
    if c.model == "ideal":
        return IdealComms(net.hops, context=beliefs["context"])
    beliefs["averaged_rows"] = config.game.virtual_mean == "outside"
    if c.model == "ns3":
        if not isinstance(provider, Ns3Provider):
            raise ConfigError(
                "comms.model = 'ns3' sends its packets through the ns3 provider's nodes: the "
                f"run's provider must be an Ns3Provider (got {type(provider).__name__})"
            )
        n, h = config.swarm.n_robots, net.hops
        return Ns3Comms(n, int(state_dim), h, provider, c.jitter_s, **beliefs)
    channel = getattr(provider, "model", None)
    if not isinstance(channel, PropagationModel):
        channel = PropagationModel(RadioParameters(**net.radio.model_dump()))
    if c.model == "csma":
        return CsmaComms(
            config.swarm.n_robots,
            int(state_dim),
            net.hops,
            channel,
            rate_mbps=c.rate_mbps,
            jitter_s=c.jitter_s,
            period_s=config.sim.control_period_s,
            loss_rate=c.loss_rate,
            **_olsr_frames(net),
            **beliefs,
        )
    return RoutedComms(
        config.swarm.n_robots,
        int(state_dim),
        net.hops,
        channel,
        hop_delay_s=c.hop_delay_s,
        rate_mbps=c.rate_mbps,
        loss_rate=c.loss_rate,
        loss_model=c.loss_model,
        ge_good_to_bad=c.ge_good_to_bad,
        ge_bad_to_good=c.ge_bad_to_good,
        ge_loss_bad=c.ge_loss_bad,
        **beliefs,
    )


def _olsr_frames(net: NetworkConfig) -> dict[str, float | None]:
    """The rates at which the run's routing protocol sends frames: OLSR's HELLOs, and its TCs
    unless it runs HELLO-only (the built-in model with h <= 2; ns-3 always sends TCs); the
    other providers send none."""
    if net.backend not in ("olsr", "ns3"):
        return {"hello_interval_s": None, "tc_interval_s": None}
    olsr = net.olsr
    flag = olsr.hello_only
    hello_only = net.backend == "olsr" and (net.hops <= 2 if flag == "auto" else bool(flag))
    return {
        "hello_interval_s": olsr.hello_interval_s,
        "tc_interval_s": None if hello_only else olsr.tc_interval_s,
    }
