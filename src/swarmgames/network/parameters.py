"""Plain radio and OLSR parameters of the network layer (immutable, no validation).

The network layer takes these instead of the configuration: the validated
:class:`~swarmgames.config.RadioConfig` and :class:`~swarmgames.config.OlsrConfig` are turned
into them once, at the configuration boundary
(:func:`swarmgames.sim.providers.provider_from_config`), so the field names, types and defaults
are the same.

References
----------
.. [1] ns-3 3.44 defaults (docs/reference.md section 2): 16.0206 dBm, Friis at 5.15 GHz, -82 dBm.
.. [2] RFC 3626 section 18 (OLSR intervals and hold times).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

__all__ = ["OlsrParameters", "RadioParameters"]


@dataclass(frozen=True)
class RadioParameters:
    """Radio propagation and reception (ns-3 3.44 defaults).

    Parameters
    ----------
    tx_power_dbm : float, default 16.0206
        Transmit power, dBm (ns-3 WifiPhy default, 40 mW).
    loss_model : {'friis', 'log_distance'}, default 'friis'
        Path-loss model.
    frequency_hz : float, default 5.15e9
        Carrier frequency for Friis, Hz (ns-3 Friis default).
    system_loss : float, default 1.0
        Friis system loss L, linear (>= 1).
    min_loss_db : float, default 0.0
        Friis minimum loss, dB.
    exponent : float, default 3.0
        Log-distance path-loss exponent n, no unit.
    reference_distance_m : float, default 1.0
        Log-distance reference distance d0, metres.
    reference_loss_db : float, default 46.6777
        Log-distance loss at the reference distance, dB.
    shadowing_sigma_db : float, default 0.0
        Log-normal shadowing standard deviation, dB (0 = off).
    nakagami_m : float or None, default None
        Nakagami-m fading shape, no unit (1 = Rayleigh; None = no fading).
    rx_threshold_dbm : float, default -82.0
        Reception threshold, dBm (-82 = 802.11a 6 Mbit/s broadcast).

    Examples
    --------
    >>> RadioParameters(shadowing_sigma_db=5.7).rx_threshold_dbm
    -82.0
    """

    tx_power_dbm: float = 16.0206
    loss_model: Literal["friis", "log_distance"] = "friis"
    frequency_hz: float = 5.15e9
    system_loss: float = 1.0
    min_loss_db: float = 0.0
    exponent: float = 3.0
    reference_distance_m: float = 1.0
    reference_loss_db: float = 46.6777
    shadowing_sigma_db: float = 0.0
    nakagami_m: float | None = None
    rx_threshold_dbm: float = -82.0


@dataclass(frozen=True)
class OlsrParameters:
    """OLSR timing (RFC 3626 section 18, ns-3 defaults).

    Parameters
    ----------
    hello_interval_s : float, default 2.0
        HELLO emission interval, seconds.
    tc_interval_s : float, default 5.0
        TC emission interval, seconds.
    max_jitter_s : float, default 0.5
        Upper bound of the uniform message jitter, seconds.
    neighbour_hold_s : float, default 6.0
        Neighbour/link hold time (3 x HELLO interval), seconds.
    topology_hold_s : float, default 15.0
        Topology hold time (3 x TC interval), seconds.
    duplicate_hold_s : float, default 30.0
        Duplicate-set hold time, seconds.
    willingness : {0, 1, 3, 6, 7}, default 3
        Willingness to relay: 0 never, 3 default, 7 always.
    hello_only : bool or 'auto', default 'auto'
        Skip TC messages; 'auto' skips them when the game needs only h <= 2 hops, where TCs
        cannot change N_i(h) (see :func:`~swarmgames.network.factory.make_provider`).

    Examples
    --------
    >>> OlsrParameters(hello_interval_s=1.0).neighbour_hold_s
    6.0
    """

    hello_interval_s: float = 2.0
    tc_interval_s: float = 5.0
    max_jitter_s: float = 0.5
    neighbour_hold_s: float = 6.0
    topology_hold_s: float = 15.0
    duplicate_hold_s: float = 30.0
    willingness: Literal[0, 1, 3, 6, 7] = 3
    hello_only: bool | Literal["auto"] = "auto"
