"""Radio propagation: received power between node pairs, with ns-3's formulas and defaults.

All functions are vectorised over pairs: distances are an array of any shape and the result has
the same shape. Random effects (log-normal shadowing, Nakagami-m fading) draw from a
``numpy.random.Generator`` passed in by the caller.

Models
------
Friis (ns-3 ``FriisPropagationLossModel``)::

    Pr = Pt - max(L_min, -10 log10(lambda^2 / (16 pi^2 d^2 L))),   lambda = c / f

and ``Pr = Pt - L_min`` for ``d <= 0`` (ns-3 returns the transmit power less the minimum loss
for co-located nodes, so ``d = 0`` gives no ``-inf`` or ``nan``).

Log-distance (ns-3 ``LogDistancePropagationLossModel``)::

    Pr = Pt - L0 - 10 n log10(d / d0)   for d > d0,   Pr = Pt - L0 otherwise.

Shadowing adds ``-X`` with ``X ~ N(0, sigma^2)`` dB; Nakagami-m fading multiplies the received
power (linear, mW) by a ``Gamma(m, 1/m)`` gain of mean 1 (m = 1 is Rayleigh).

References
----------
.. [1] ns-3 3.44, ``src/propagation/model/propagation-loss-model.cc`` (Friis, LogDistance) and
   ``nakagami-propagation-loss-model.cc``.
.. [2] REFERENCE.md section 2 (defaults: 16.0206 dBm, 5.15 GHz, L = 1, n = 3, d0 = 1 m,
   L0 = 46.6777 dB, -82 dBm reception threshold, range 368.84 m).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from swarmgames.config import RadioConfig

__all__ = [
    "SPEED_OF_LIGHT",
    "PropagationModel",
    "friis_rx_power",
    "log_distance_rx_power",
    "max_range",
]

#: Speed of light in vacuum, m/s (the value ns-3 uses).
SPEED_OF_LIGHT = 299_792_458.0

#: Tail probability used to bound the random range (shadowing / fading): a pair farther than the
#: bound would be linked with probability below this.
RANGE_TAIL_PROBABILITY = 1e-6


def friis_rx_power(
    distance: np.ndarray,
    tx_power_dbm: float = 16.0206,
    frequency_hz: float = 5.15e9,
    system_loss: float = 1.0,
    min_loss_db: float = 0.0,
) -> np.ndarray:
    """Received power (dBm) under the Friis free-space model, as ns-3 computes it.

    Parameters
    ----------
    distance : array_like
        Transmitter-receiver distances, metres (any shape; ``<= 0`` means co-located).
    tx_power_dbm : float
        Transmit power, dBm.
    frequency_hz : float
        Carrier frequency f, Hz.
    system_loss : float
        System loss L (linear, >= 1).
    min_loss_db : float
        Minimum loss, dB: the loss is ``max(L_min, Friis loss)``.

    Returns
    -------
    ndarray of float
        ``Pt - max(L_min, 20 log10(4 pi d f / c) + 10 log10 L)``; ``Pt - L_min`` where
        ``d <= 0``.

    Examples
    --------
    >>> round(float(friis_rx_power(368.84)), 2)
    -82.0
    >>> float(friis_rx_power(0.0))
    16.0206
    """
    d = np.asarray(distance, dtype=float)
    lam = SPEED_OF_LIGHT / frequency_hz
    positive = d > 0
    safe = np.where(positive, d, 1.0)
    loss = 20.0 * np.log10(4.0 * np.pi * safe / lam) + 10.0 * np.log10(system_loss)
    loss = np.maximum(loss, min_loss_db)
    return np.where(positive, tx_power_dbm - loss, tx_power_dbm - min_loss_db)


def log_distance_rx_power(
    distance: np.ndarray,
    tx_power_dbm: float = 16.0206,
    exponent: float = 3.0,
    reference_distance_m: float = 1.0,
    reference_loss_db: float = 46.6777,
) -> np.ndarray:
    """Received power (dBm) under the log-distance model, as ns-3 computes it.

    ``Pr = Pt - L0 - 10 n log10(d / d0)`` for ``d > d0`` and ``Pt - L0`` otherwise (so ``d = 0``
    is finite).

    Examples
    --------
    >>> round(float(log_distance_rx_power(10.0)), 4)
    -60.6571
    """
    d = np.asarray(distance, dtype=float)
    far = d > reference_distance_m
    ratio = np.where(far, d, reference_distance_m) / reference_distance_m
    return tx_power_dbm - reference_loss_db - 10.0 * exponent * np.log10(ratio)


@dataclass(frozen=True)
class PropagationModel:
    """A configured path-loss + reception model (immutable).

    Parameters
    ----------
    radio : RadioConfig
        Transmit power, loss model and its parameters, shadowing, fading, reception threshold.

    Notes
    -----
    A frame is received when its power is at least ``radio.rx_threshold_dbm`` (ns-3's -82 dBm
    preamble-detection gate at 6 Mbit/s, REFERENCE.md section 2).
    """

    radio: RadioConfig = field(default_factory=RadioConfig)

    @property
    def random(self) -> bool:
        """Whether received power is random (shadowing or fading switched on)."""
        return self.radio.shadowing_sigma_db > 0 or self.radio.nakagami_m is not None

    def mean_rx_power(self, distance: np.ndarray) -> np.ndarray:
        """Deterministic (path-loss only) received power, dBm."""
        r = self.radio
        if r.loss_model == "friis":
            return friis_rx_power(
                distance, r.tx_power_dbm, r.frequency_hz, r.system_loss, r.min_loss_db
            )
        return log_distance_rx_power(
            distance, r.tx_power_dbm, r.exponent, r.reference_distance_m, r.reference_loss_db
        )

    def rx_power(self, distance: np.ndarray, rng: np.random.Generator | None = None) -> np.ndarray:
        """Received power, dBm, with shadowing and fading drawn from ``rng`` when switched on.

        Raises
        ------
        ValueError
            If the model is random and no ``rng`` is given.
        """
        p = self.mean_rx_power(distance)
        if not self.random:
            return p
        if rng is None:
            raise ValueError("rng must be a numpy Generator when shadowing or fading is on")
        r = self.radio
        if r.shadowing_sigma_db > 0:
            p = p - rng.normal(0.0, r.shadowing_sigma_db, size=p.shape)
        if r.nakagami_m is not None:
            gain = rng.gamma(r.nakagami_m, 1.0 / r.nakagami_m, size=p.shape)
            with np.errstate(divide="ignore"):
                p = p + 10.0 * np.log10(gain)
        return p

    def max_range(self) -> float:
        """Largest distance at which a link is possible (deterministic models) or likely beyond
        a tail probability of ``1e-6`` (random models), metres.

        With shadowing (sigma dB) and Nakagami-m fading, the bound is the distance at which the
        mean power plus the ``1 - 1e-6`` quantile of the random gain reaches the threshold.
        """
        return max_range(self.radio)


def _random_margin_db(radio: RadioConfig) -> float:
    margin = 0.0
    if radio.shadowing_sigma_db > 0:
        margin += radio.shadowing_sigma_db * float(stats.norm.isf(RANGE_TAIL_PROBABILITY))
    if radio.nakagami_m is not None:
        m = radio.nakagami_m
        margin += 10.0 * np.log10(float(stats.gamma.isf(RANGE_TAIL_PROBABILITY, m, scale=1 / m)))
    return margin


def max_range(radio: RadioConfig) -> float:
    """Distance (m) beyond which no link is possible (or only with probability < 1e-6).

    Friis: ``d_max = (c / f) / (4 pi) * 10^((Pt - Pth + M - 10 log10 L) / 20)``; log-distance:
    ``d_max = d0 * 10^((Pt - L0 - Pth + M) / (10 n))``, where ``M`` is the random margin (0 for
    deterministic models). If ``L_min`` already keeps every power below the threshold, the range
    is 0.

    Examples
    --------
    >>> round(max_range(RadioConfig()), 2)
    368.84
    """
    budget = radio.tx_power_dbm - radio.rx_threshold_dbm + _random_margin_db(radio)
    if radio.loss_model == "friis":
        if budget < radio.min_loss_db:
            return 0.0
        lam = SPEED_OF_LIGHT / radio.frequency_hz
        return float(lam / (4 * np.pi) * 10 ** ((budget - 10 * np.log10(radio.system_loss)) / 20))
    if budget < radio.reference_loss_db:
        return 0.0
    return float(
        radio.reference_distance_m
        * 10 ** ((budget - radio.reference_loss_db) / (10 * radio.exponent))
    )
