"""The configuration boundary of the network layer (:mod:`swarmgames.sim.providers`)."""

from __future__ import annotations

import dataclasses
import typing

import numpy as np
import pytest

from swarmgames.config import NetworkConfig, OlsrConfig, RadioConfig
from swarmgames.network.factory import BACKENDS, make_provider
from swarmgames.network.parameters import OlsrParameters, RadioParameters
from swarmgames.sim.providers import provider_from_config

LINE = np.c_[np.arange(5) * 300.0, np.zeros(5), np.zeros(5)]


@pytest.mark.parametrize(
    ("config", "parameters"), [(RadioConfig, RadioParameters), (OlsrConfig, OlsrParameters)]
)
def test_parameters_mirror_the_configuration(config, parameters):
    # Same names, in the same order, with the same types and defaults: they cannot drift.
    fields = {f.name: f for f in dataclasses.fields(parameters)}
    hints = typing.get_type_hints(parameters)
    assert list(fields) == list(config.model_fields)
    for name, info in config.model_fields.items():
        assert fields[name].default == info.default, name
        assert hints[name] == info.annotation, name


def test_backend_names_are_defined_once():
    assert typing.get_args(NetworkConfig.model_fields["backend"].annotation) == BACKENDS


def test_default_configuration_gives_default_parameters():
    assert RadioParameters(**RadioConfig().model_dump()) == RadioParameters()
    assert OlsrParameters(**OlsrConfig().model_dump()) == OlsrParameters()


@pytest.mark.parametrize("backend", ["olsr", "oracle", "disk", "knn"])
def test_config_and_plain_parameters_build_the_same_network(backend):
    network = NetworkConfig(
        backend=backend, hops=3, disk_radius_m=320.0, knn_k=2, radio={"tx_power_dbm": 18.0}
    )
    a = provider_from_config(network, 5, 4)
    b = make_provider(
        backend,
        5,
        4,
        hops=3,
        radio=RadioParameters(tx_power_dbm=18.0),
        disk_radius_m=320.0,
        knn_k=2,
    )
    for p in (a, b):
        p.reset(LINE)
    for t in (5.0, 20.0):
        assert np.array_equal(a.advance(t, LINE).hop_matrix(), b.advance(t, LINE).hop_matrix())


def test_keyword_arguments_reach_the_factory():
    assert not provider_from_config(NetworkConfig(hops=2), 3, full_tables=True).hello_only
    with pytest.raises(TypeError, match="unexpected keyword argument 'tables'"):
        provider_from_config(NetworkConfig(), 3, tables=True)
