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

Shadowing is *static per pair of robots*: with a ``shadowing_key`` the loss of the pair
``{i, j}`` is a fixed draw for the whole run (:func:`pair_gaussians`, a counter-based draw keyed
by a number taken from the provider's Generator), as the ns-3 backend does with a
``MatrixPropagationLossModel``. Providers built on the same key see the same channel, so
``compare`` measures two backends on one channel realisation. Fading stays random per evaluation.

References
----------
.. [1] ns-3 3.44, ``src/propagation/model/propagation-loss-model.cc`` (Friis, LogDistance) and
   ``nakagami-propagation-loss-model.cc``.
.. [2] docs/reference.md section 2 (defaults: 16.0206 dBm, 5.15 GHz, L = 1, n = 3, d0 = 1 m,
   L0 = 46.6777 dB, -82 dBm reception threshold, range 368.84 m).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from swarmgames.network.parameters import RadioParameters

__all__ = [
    "SPEED_OF_LIGHT",
    "PropagationModel",
    "channel_model",
    "friis_rx_power",
    "log_distance_rx_power",
    "max_range",
    "new_shadowing_key",
    "pair_gaussians",
]

#: Speed of light in vacuum, m/s (the value ns-3 uses).
SPEED_OF_LIGHT = 299_792_458.0

#: Tail probability used to bound the random range (shadowing / fading): a pair farther than the
#: bound would be linked with probability below this.
RANGE_TAIL_PROBABILITY = 1e-6


_MASK64 = np.uint64(0xFFFFFFFFFFFFFFFF)


def _splitmix64(x: np.ndarray) -> np.ndarray:
    # Steele, Lea and Flood, "Fast splittable pseudorandom number generators", OOPSLA 2014.
    x = x + np.uint64(0x9E3779B97F4A7C15)
    x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return x ^ (x >> np.uint64(31))


def pair_gaussians(i: np.ndarray, j: np.ndarray, key: int) -> np.ndarray:
    """Standard normal draws, one per unordered pair ``{i, j}``, fixed by ``key``.

    A counter-based generator: the draw of a pair depends only on ``(key, min(i, j),
    max(i, j))``, so it is the same whenever and in whichever order the pair is evaluated, and
    no N x N table is stored (10 000 robots have 5e7 pairs).

    Examples
    --------
    >>> a = pair_gaussians(np.array([0, 3]), np.array([3, 0]), key=7)
    >>> bool(a[0] == a[1])
    True
    """
    from scipy.special import ndtri

    lo = np.minimum(i, j).astype(np.uint64)
    hi = np.maximum(i, j).astype(np.uint64)
    with np.errstate(over="ignore"):
        h = _splitmix64(_splitmix64(np.uint64(key) ^ lo) ^ (hi * np.uint64(0xD1B54A32D192ED03)))
    u = ((h >> np.uint64(11)).astype(np.float64) + 0.5) * 2.0**-53  # in (0, 1)
    return ndtri(u)


def new_shadowing_key(rng: np.random.Generator) -> int:
    """A shadowing key drawn from ``rng`` (the provider's seeded Generator)."""
    return int(rng.integers(0, 2**63))


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
    radio : RadioParameters
        Transmit power, loss model and its parameters, shadowing, fading, reception threshold.

    Notes
    -----
    A frame is received when its power is at least ``radio.rx_threshold_dbm`` (ns-3's -82 dBm
    preamble-detection gate at 6 Mbit/s, docs/reference.md section 2).
    """

    radio: RadioParameters = field(default_factory=RadioParameters)
    shadowing_key: int | None = None

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

    def rx_power(
        self,
        distance: np.ndarray,
        rng: np.random.Generator | None = None,
        pairs: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> np.ndarray:
        """Received power, dBm, with shadowing and fading when switched on.

        Parameters
        ----------
        distance : ndarray
            Distances, metres.
        rng : numpy Generator, optional
            Source of fading draws (and of shadowing draws without a key).
        pairs : (i, j) arrays of the distances' shape, optional
            Robot indices of each distance. With ``shadowing_key`` set, the shadowing of a pair
            is its static draw (:func:`pair_gaussians`); otherwise it is drawn from ``rng``.

        Raises
        ------
        ValueError
            If a random effect needs ``rng`` and none is given.
        """
        p = self.mean_rx_power(distance)
        if not self.random:
            return p
        r = self.radio
        static = pairs is not None and self.shadowing_key is not None
        if rng is None and (r.nakagami_m is not None or not static):
            raise ValueError("rng must be a numpy Generator when shadowing or fading is on")
        if r.shadowing_sigma_db > 0:
            if static:
                z = pair_gaussians(pairs[0], pairs[1], self.shadowing_key)
            else:
                z = rng.normal(0.0, 1.0, size=p.shape)
            p = p - r.shadowing_sigma_db * z
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


def channel_model(
    radio: RadioParameters, rng: np.random.Generator, shadowing_key: int | None = None
) -> PropagationModel:
    """The propagation model of a provider: with shadowing on, a static per-pair channel keyed
    by ``shadowing_key`` or, if None, by a key drawn from ``rng`` (only then, so runs without
    shadowing draw exactly what they drew before)."""
    if radio.shadowing_sigma_db > 0 and shadowing_key is None:
        shadowing_key = new_shadowing_key(rng)
    return PropagationModel(radio, shadowing_key if radio.shadowing_sigma_db > 0 else None)


def _random_margin_db(radio: RadioParameters) -> float:
    # The normal's and the gamma(m, 1/m) law's upper quantiles, exactly as scipy.stats'
    # norm.isf and gamma.isf compute them, without importing scipy.stats (0.4 s).
    from scipy.special import gammainccinv, ndtri

    margin = 0.0
    if radio.shadowing_sigma_db > 0:
        margin += radio.shadowing_sigma_db * float(-ndtri(RANGE_TAIL_PROBABILITY))
    if radio.nakagami_m is not None:
        m = radio.nakagami_m
        margin += 10.0 * np.log10(float(gammainccinv(m, RANGE_TAIL_PROBABILITY) * (1 / m)))
    return margin


def max_range(radio: RadioParameters) -> float:
    """Distance (m) beyond which no link is possible (or only with probability < 1e-6).

    Friis: ``d_max = (c / f) / (4 pi) * 10^((Pt - Pth + M - 10 log10 L) / 20)``; log-distance:
    ``d_max = d0 * 10^((Pt - L0 - Pth + M) / (10 n))``, where ``M`` is the random margin (0 for
    deterministic models). If ``L_min`` already keeps every power below the threshold, the range
    is 0.

    Examples
    --------
    >>> round(max_range(RadioParameters()), 2)
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
