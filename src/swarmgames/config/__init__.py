"""Configuration: the validated scenario schema (:mod:`~swarmgames.config.schema`), reading and
writing scenario files (:mod:`~swarmgames.config.io`) and constant-density scenarios of any
size (:func:`scaled_config`)."""

from swarmgames.config.io import (
    apply_overrides,
    builtin_scenarios,
    format_validation_error,
    load_config,
    parse_config,
    resolve_scenario,
    to_data,
    to_toml,
)
from swarmgames.config.scaling import scaled_config
from swarmgames.config.schema import (
    CommsConfig,
    FaultsConfig,
    GameConfig,
    NetworkConfig,
    OlsrConfig,
    RadioConfig,
    ScenarioConfig,
    SimConfig,
    SwarmConfig,
)

__all__ = [
    "CommsConfig",
    "FaultsConfig",
    "GameConfig",
    "NetworkConfig",
    "OlsrConfig",
    "RadioConfig",
    "ScenarioConfig",
    "SimConfig",
    "SwarmConfig",
    "apply_overrides",
    "builtin_scenarios",
    "format_validation_error",
    "load_config",
    "parse_config",
    "resolve_scenario",
    "scaled_config",
    "to_data",
    "to_toml",
]
