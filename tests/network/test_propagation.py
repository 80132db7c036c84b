"""Propagation models against ns-3's formulas and the ranges measured in ns-3
(docs/reference.md section 2)."""

import warnings

import numpy as np
import pytest

from swarmgames.network.parameters import RadioParameters
from swarmgames.network.propagation import (
    PropagationModel,
    friis_rx_power,
    log_distance_rx_power,
    max_range,
)

#: 802.11a minimum receiver sensitivity (dBm) per OFDM rate (Mbit/s), IEEE 802.11-2016
#: Table 17-18; ns-3's preamble-detection gate is -82 dBm at 6 Mbit/s.
SENSITIVITY_80211A_DBM = {6: -82, 9: -81, 12: -79, 18: -77, 24: -74, 36: -70, 48: -66, 54: -65}


def test_friis_default_budget():
    # docs/reference.md section 2: Pr = 16.0206 - 46.684 - 20 log10(d) at 5.15 GHz.
    d = np.array([1.0, 10.0, 368.84])
    assert np.allclose(friis_rx_power(d), 16.0206 - 46.684 - 20 * np.log10(d), atol=1e-3)


def test_default_range_is_368_84_m():
    # docs/reference.md section 2: ns-3 links at 368.5 m and not at 369 m; d_max = 368.84 m.
    assert max_range(RadioParameters()) == pytest.approx(368.84, abs=0.01)
    assert friis_rx_power(368.5) >= -82.0
    assert friis_rx_power(369.0) < -82.0


def test_range_formula_with_system_loss():
    # docs/reference.md section 2: d_max = (c/f)/(4 pi) 10^((Pt + 82 - 10 log10 L)/20).
    radio = RadioParameters(system_loss=2.0)
    expected = (299_792_458 / 5.15e9) / (4 * np.pi) * 10 ** ((16.0206 + 82 - 10 * np.log10(2)) / 20)
    assert max_range(radio) == pytest.approx(expected)


@pytest.mark.parametrize("rate, sensitivity", sorted(SENSITIVITY_80211A_DBM.items()))
def test_range_shrinks_with_rate_sensitivity(rate, sensitivity):
    # 802.11a sensitivities per rate, docs/reference.md section 2: higher rates need more power.
    r = max_range(RadioParameters(rx_threshold_dbm=sensitivity))
    assert r <= max_range(RadioParameters()) + 1e-9
    assert friis_rx_power(r) == pytest.approx(sensitivity)


def test_colocated_nodes_get_tx_power_without_warnings():
    # ns-3 Friis returns Pt - L_min for d <= 0; log-distance returns Pt - L0 for d <= d0.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        p = friis_rx_power(np.array([0.0, 0.0]))
        q = log_distance_rx_power(np.array([0.0, 0.5]))
    assert np.all(p == 16.0206)
    assert np.allclose(q, 16.0206 - 46.6777)


def test_min_loss_caps_friis_loss():
    # ns-3 FriisPropagationLossModel: loss = max(MinLoss, Friis loss).
    assert friis_rx_power(1.0, min_loss_db=60.0) == pytest.approx(16.0206 - 60.0)


def test_log_distance_formula():
    # ns-3 LogDistancePropagationLossModel: Pr = Pt - L0 - 10 n log10(d / d0).
    assert log_distance_rx_power(100.0, exponent=3.0) == pytest.approx(16.0206 - 46.6777 - 60.0)
    radio = RadioParameters(loss_model="log_distance")
    r = max_range(radio)
    assert log_distance_rx_power(r) == pytest.approx(-82.0)


def test_shadowing_is_seeded_and_zero_mean():
    model = PropagationModel(RadioParameters(shadowing_sigma_db=5.7))
    d = np.full(20_000, 100.0)
    a = model.rx_power(d, np.random.default_rng(1))
    b = model.rx_power(d, np.random.default_rng(1))
    assert np.array_equal(a, b)
    assert a.mean() == pytest.approx(float(friis_rx_power(100.0)), abs=0.2)
    assert a.std() == pytest.approx(5.7, rel=0.05)


def test_nakagami_gain_has_unit_mean():
    # Nakagami-m power gain ~ Gamma(m, 1/m): mean 1 in linear units (m = 1 is Rayleigh).
    model = PropagationModel(RadioParameters(nakagami_m=1.0))
    p = model.rx_power(np.full(50_000, 100.0), np.random.default_rng(2))
    linear = 10 ** ((p - friis_rx_power(100.0)) / 10)
    assert linear.mean() == pytest.approx(1.0, rel=0.03)


def test_random_model_needs_rng():
    with pytest.raises(ValueError, match="rng must be a numpy Generator"):
        PropagationModel(RadioParameters(shadowing_sigma_db=3.0)).rx_power(np.ones(2))


def test_random_range_bound_exceeds_deterministic_range():
    assert max_range(RadioParameters(shadowing_sigma_db=5.7)) > max_range(RadioParameters())


def test_no_range_when_min_loss_exceeds_budget():
    assert max_range(RadioParameters(min_loss_db=200.0)) == 0.0


@pytest.mark.parametrize("sigma, m", [(0.0, None), (4.0, None), (0.0, 1.0), (8.0, 0.7), (3.0, 5.0)])
def test_random_margin_equals_scipy_stats_quantiles(sigma, m):
    # The fading and shadowing margin uses scipy.special; scipy.stats' norm.isf and gamma.isf
    # must give the same float, bit for bit.
    from scipy import stats

    from swarmgames.network.propagation import RANGE_TAIL_PROBABILITY, _random_margin_db

    p = RANGE_TAIL_PROBABILITY
    expected = sigma * float(stats.norm.isf(p)) if sigma > 0 else 0.0
    if m is not None:
        expected += 10.0 * np.log10(float(stats.gamma.isf(p, m, scale=1 / m)))
    radio = RadioParameters(shadowing_sigma_db=sigma, nakagami_m=m)
    assert _random_margin_db(radio) == expected
