"""Validated configuration of a swarmgames scenario.

Every field is typed, carries its unit in its description, has a default and declares its
constraints (pydantic v2). Unknown keys are rejected. Errors are collected into one
:class:`~swarmgames.errors.ConfigError` whose message names each field path, the rule broken and
the value given, e.g. ``game.beta: must be > 0 (got -1.0)``.

Scenario files are TOML with one table per section::

    name = "coverage"
    seed = 7

    [swarm]
    n_robots = 7

    [game]
    alpha_b = 0.001

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop (arXiv 2205.02203).
.. [2] RFC 3626, "Optimized Link State Routing Protocol (OLSR)", sections 6-10 and 18.
"""

from __future__ import annotations

import re
from typing import Any, Literal

from pydantic import Field, SerializeAsAny, field_validator, model_validator

from swarmgames.names import (
    BACKENDS,
    COMMS_MODELS,
    CONTROLLERS,
    ENGINES,
    GAME_SOLVERS,
    PAIR_WEIGHTINGS,
    REFINE_METHODS,
    VIRTUAL_MEANS,
)
from swarmgames.section import Coordinate, Section

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
]

_Section = Section

#: Longest simulated time of a run, warm-up or mission, seconds (11.6 days): the network
#: simulates every message of it, so 1e12 s would run for ever without a word.
MAX_SIM_TIME_S = 1e6

#: Most stages of a run: every stage's states and metrics are kept in memory.
MAX_STAGES = 1_000_000

#: A scenario name is a single folder name that cannot be ``.``, ``..`` or hidden.
NAME_PATTERN = r"^[A-Za-z0-9_][A-Za-z0-9_.-]*$"


class RadioConfig(_Section):
    """Radio propagation and reception (ns-3 3.44 defaults)."""

    tx_power_dbm: float = Field(
        16.0206, ge=-30, le=60, description="Transmit power, dBm (ns-3 WifiPhy default, 40 mW)."
    )
    loss_model: Literal["friis", "log_distance"] = Field(
        "friis", description="Path-loss model: 'friis' or 'log_distance'."
    )
    frequency_hz: float = Field(
        5.15e9, gt=0, description="Carrier frequency for Friis, Hz (ns-3 Friis default)."
    )
    system_loss: float = Field(1.0, ge=1.0, description="Friis system loss L, linear (>= 1).")
    min_loss_db: float = Field(0.0, ge=0, description="Friis minimum loss, dB.")
    exponent: float = Field(3.0, gt=0, description="Log-distance path-loss exponent n.")
    reference_distance_m: float = Field(
        1.0, gt=0, description="Log-distance reference distance d0, metres."
    )
    reference_loss_db: float = Field(
        46.6777, description="Log-distance loss at the reference distance, dB."
    )
    shadowing_sigma_db: float = Field(
        0.0, ge=0, description="Log-normal shadowing standard deviation, dB (0 = off)."
    )
    nakagami_m: float | None = Field(
        None, ge=0.5, description="Nakagami-m fading shape (1 = Rayleigh); omit for no fading."
    )
    rx_threshold_dbm: float = Field(
        -82.0, le=0, description="Reception threshold, dBm (-82 = 802.11a 6 Mbit/s broadcast)."
    )


class OlsrConfig(_Section):
    """OLSR timing (RFC 3626 section 18, ns-3 defaults)."""

    hello_interval_s: float = Field(2.0, gt=0, description="HELLO emission interval, seconds.")
    tc_interval_s: float = Field(5.0, gt=0, description="TC emission interval, seconds.")
    max_jitter_s: float = Field(
        0.5,
        ge=0,
        description="Upper bound of the uniform message jitter; below hello_interval_s, seconds.",
    )
    neighbour_hold_s: float = Field(
        6.0, gt=0, description="Neighbour/link hold time (3 x HELLO interval), seconds."
    )
    topology_hold_s: float = Field(
        15.0, gt=0, description="Topology hold time (3 x TC interval), seconds."
    )
    duplicate_hold_s: float = Field(30.0, gt=0, description="Duplicate-set hold time, seconds.")
    willingness: Literal[0, 1, 3, 6, 7] = Field(
        3, description="Willingness to relay: 0 never, 3 default, 7 always."
    )
    hello_only: bool | Literal["auto"] = Field(
        "auto",
        description=(
            "Skip TC messages. 'auto' skips them when the game needs only h <= 2 hops, where "
            "TCs cannot change N_i(h)."
        ),
    )

    @field_validator("willingness", mode="before")
    @classmethod
    def _willingness_is_an_integer(cls, value: Any) -> Any:
        # A Literal of ints takes true as 1 and 1.0 as 1, even in strict mode.
        if isinstance(value, (bool, float)):
            raise ValueError(f"must be one of the integers 0, 1, 3, 6, 7 (got {value!r})")
        return value

    @field_validator("hello_only", mode="before")
    @classmethod
    def _hello_only_choice(cls, value: Any) -> Any:
        # One line for the field, not one per alternative of the union.
        if not (isinstance(value, bool) or value == "auto"):
            raise ValueError(f"must be true, false or 'auto' (got {value!r})")
        return value

    @model_validator(mode="after")
    def _holds_cover_intervals(self) -> OlsrConfig:
        if self.max_jitter_s >= self.hello_interval_s:
            # Each HELLO round must be on the air before the next one is built (ns-3 uses a
            # quarter of the HELLO interval); the OLSR model refuses to start otherwise.
            raise ValueError(
                "max_jitter_s must be < hello_interval_s "
                f"(got {self.max_jitter_s} >= {self.hello_interval_s})"
            )
        if self.neighbour_hold_s <= self.hello_interval_s:
            raise ValueError(
                "neighbour_hold_s must be > hello_interval_s "
                f"(got {self.neighbour_hold_s} <= {self.hello_interval_s})"
            )
        if self.topology_hold_s <= self.tc_interval_s:
            raise ValueError(
                "topology_hold_s must be > tc_interval_s "
                f"(got {self.topology_hold_s} <= {self.tc_interval_s})"
            )
        return self


class NetworkConfig(_Section):
    """How each robot's neighbourhood N_i(h) is obtained."""

    backend: Literal[BACKENDS] = Field(
        "olsr",
        description=(
            "Neighbourhood provider: 'olsr' (built-in RFC 3626 model), 'oracle' (instant "
            "shortest paths), 'disk' (fixed radius), 'knn' (k nearest), 'ns3' (ns-3 simulator)."
        ),
    )
    hops: int = Field(2, ge=1, le=64, description="Neighbourhood radius h, hops (paper: 2).")
    disk_radius_m: float = Field(368.84, gt=0, description="Radius of the 'disk' baseline, metres.")
    knn_k: int = Field(
        4, ge=1, le=100_000, description="Number of neighbours of the 'knn' baseline."
    )
    radio: RadioConfig = Field(default_factory=RadioConfig)
    olsr: OlsrConfig = Field(default_factory=OlsrConfig)


class CommsConfig(_Section):
    """How state messages reach the robots (the communication layer, docs/comms.md)."""

    model: Literal[COMMS_MODELS] = Field(
        "csma",
        description=(
            "'csma' (default): messages flooded hop by hop over one shared 802.11a channel "
            "(jitter, carrier sense, backoff, airtime; a frame is lost when other frames "
            "drown it), into belief tables; 'routed': the same flooding with a fixed delay "
            "per hop and configured loss, but infinite capacity; 'ideal': every member of "
            "N_i(h) gets the exact state instantly and for free (the paper's assumption); "
            "'ns3': the same flooding as UDP packets in ns-3 (needs network.backend = 'ns3')."
        ),
    )
    jitter_s: float = Field(
        0.04,
        ge=0,
        le=1.0,
        description=(
            "'csma' and 'ns3' models: every transmission (a message or a relay) first waits a "
            "uniform random time in [0, jitter_s], so that the robots do not all collide, "
            "seconds."
        ),
    )
    hop_delay_s: float = Field(
        0.002,
        ge=0,
        le=1.0,
        description="'routed' model: delay of each hop besides the frame's airtime (channel "
        "access), seconds.",
    )
    rate_mbps: float = Field(
        6.0, gt=0, le=1000.0, description="PHY rate of the state messages, Mbit/s."
    )
    decide_after_s: float = Field(
        0.1,
        ge=0,
        description=(
            "The robots decide this long after the stage time; later messages wait for the "
            "next decision, seconds."
        ),
    )
    loss_rate: float = Field(
        0.0,
        ge=0,
        le=1,
        description=(
            "Probability that one transmission is lost (i.i.d.; with the Gilbert-Elliott "
            "model, the loss of a link in its good state)."
        ),
    )
    loss_model: Literal["iid", "gilbert_elliott"] = Field(
        "iid",
        description=(
            "'iid': every transmission lost independently; 'gilbert_elliott': each link "
            "switches between a good and a bad state from stage to stage (losses in bursts)."
        ),
    )
    ge_good_to_bad: float = Field(
        0.05,
        ge=0,
        le=1,
        description="Gilbert-Elliott: probability per stage that a good link turns bad.",
    )
    ge_bad_to_good: float = Field(
        0.5,
        ge=0,
        le=1,
        description="Gilbert-Elliott: probability per stage that a bad link recovers.",
    )
    ge_loss_bad: float = Field(
        1.0, ge=0, le=1, description="Gilbert-Elliott: loss probability of a link in the bad state."
    )
    max_age_s: float = Field(
        3.0, gt=0, description="States older than this are dropped from the games, seconds."
    )
    dead_reckoning: bool = Field(
        False,
        description="Advance reported positions by reported velocities over their age "
        "(acceleration action set only).",
    )


class GameConfig(_Section):
    """Stage graphical game and its solver (paper section II.B-C, Algorithm 1)."""

    alpha_a: float = Field(1.0, ge=0, description="Weight of the unary potentials (paper: 1).")
    alpha_b: float = Field(
        0.001, ge=0, description="Weight of the pairwise potentials (paper: 0.001)."
    )
    pair_weighting: Literal[PAIR_WEIGHTINGS] = Field(
        "sum",
        description="How a local game of K robots weights its pairwise terms: sum (every pair "
        "alpha_b, eq. 1: a robot's pairwise payoff grows with its neighbourhood) or mean "
        "(alpha_b / (K - 1): alpha_b times the mean over its partners, the same pull at any "
        "size). Not with solver = 'centralised'.",
    )
    solver: Literal[GAME_SOLVERS] = Field(
        "mean_field",
        description=(
            "Local-game solver: mean_field (Algorithm 1), best_response, exact (enumeration), "
            "centralised (one swarm-wide mean-field game), random."
        ),
    )
    refine: Literal[REFINE_METHODS] = Field(
        "none",
        description=(
            "Refinement of every local game's solved profile: none (the solver's profile, "
            "Algorithm 1 alone) or best_response (best-response sweeps from it to a pure "
            "Nash equilibrium of the local game: local regret exactly 0; the owner plays "
            "its refined action)."
        ),
    )
    virtual_mean: Literal[VIRTUAL_MEANS] = Field(
        "eq3",
        description="How a neighbour whose own neighbourhood reaches outside the local game "
        "stands in for the outside: eq3 (the paper's virtual mean over N_j, eq. 3; true is "
        "the same), outside (the mean over N_j - N_i only), exact (the outside robots "
        "themselves as fixed context, their states flooded to 2h hops), off (reported states; "
        "false is the same).",
    )
    beta: float = Field(
        50.0, gt=0, description="Inverse temperature of Q_j(x) ∝ exp(beta · E[M_i | x]), 1/payoff."
    )
    delta: float = Field(1e-6, gt=0, description="KL(Q_old || Q) stopping threshold, nats.")
    max_iter: int = Field(200, ge=1, le=1_000_000, description="Maximum mean-field sweeps.")
    action_choice: Literal["argmax", "sample"] = Field(
        "argmax", description="How a robot picks its action from its own marginal."
    )
    dtype: Literal["float64", "float32"] = Field(
        "float64",
        description="Floating-point precision of the payoff tables and marginals (float32 "
        "halves the memory of the pairwise table, B K^2 A^2 values).",
    )
    engine: Literal[ENGINES] = Field(
        "auto",
        description="Mean-field engine: compiled (Numba kernel, all cores), blas or sequential "
        "(numpy); auto = compiled when Numba is installed. They agree to rounding.",
    )
    max_profiles: int = Field(
        1_000_000,
        ge=1,
        le=1_000_000_000,
        description="Largest number of joint profiles the exact solver enumerates per game.",
    )
    buckets: int = Field(
        0,
        ge=0,
        le=1024,
        description="Local games are solved in this many batches of similar neighbourhood "
        "size (less padding); 0 = automatic (one per 128 robots, at most 8).",
    )

    @field_validator("virtual_mean", mode="before")
    @classmethod
    def _virtual_mean_switch(cls, value: Any) -> Any:
        # A boolean names two of the variants (true = 'eq3', false = 'off'); anything else
        # that is not one of their names is refused (1 is not true here).
        if isinstance(value, bool):
            return "eq3" if value else "off"
        if not isinstance(value, str) or value not in VIRTUAL_MEANS:
            raise ValueError(
                f"must be one of {', '.join(map(repr, VIRTUAL_MEANS))}, true (= 'eq3') or "
                f"false (= 'off') (got {value!r})"
            )
        return value

    @field_validator("solver", mode="before")
    @classmethod
    def _renamed_solver(cls, value: Any) -> Any:
        if value == "no_virtual_mean":
            raise ValueError(
                "'no_virtual_mean' is not a solver: set game.solver = 'mean_field' and "
                "game.virtual_mean = false (got 'no_virtual_mean')"
            )
        return value


class SwarmConfig(_Section):
    """The UAVs: number, take-off area, motion.

    Defaults where the paper is silent: 7 UAVs (the paper's largest swarm); flight at 30 m
    (a typical low-altitude survey height, well below the 368.84 m radio range, so altitude
    barely changes the links); all UAVs take off from one common disc of 25 m radius at the
    edge of the ROI, so the swarm starts as a single-hop clique and its links break and form as
    it spreads (a swarm of more than 21 UAVs takes off from a disc grown to about 20 radio
    neighbours per UAV, so that its local games stay small); 10 m moves per 1 s period
    (10 m/s, a small multirotor's cruise speed) along 8 headings plus "stay" (a 3 x 3
    "king's move" set, as the authors' grid controllers).
    """

    n_robots: int = Field(7, ge=1, le=100_000, description="Number of UAVs.")
    altitude_m: float = Field(30.0, ge=0, description="Flight altitude above ground, metres.")
    start_center_m: tuple[Coordinate, Coordinate] = Field(
        (-300.0, 0.0), description="Centre of the common take-off area (x, y), metres."
    )
    start_radius_m: float = Field(
        25.0,
        ge=0,
        description="Radius of the take-off disc, metres (uniform start positions); grown for "
        "a swarm of more than start_max_neighbours + 1 UAVs.",
    )
    start_max_neighbours: int = Field(
        20,
        ge=0,
        le=100_000,
        description="Larger swarms take off from a disc grown so that a UAV has on average at "
        "most this many others within start_neighbour_range_m: radius max(start_radius_m, "
        "range sqrt((n_robots - 1) / start_max_neighbours)); 0 = always start_radius_m.",
    )
    start_neighbour_range_m: float = Field(
        368.84,
        gt=0,
        le=1e6,
        description="Distance within which take-off neighbours are counted (the default "
        "radio range), metres.",
    )
    step_m: float = Field(
        10.0, gt=0, description="Distance flown by one move action per control period, metres."
    )
    n_headings: int = Field(
        8, ge=1, le=64, description="Number of headings of the move actions (plus 'stay')."
    )
    action_set: Literal["headings", "acceleration"] = Field(
        "headings",
        description=(
            "'headings': stay + n_headings moves of step_m; 'acceleration': (2 accel_levels "
            "+ 1)^2 acceleration labels rolled forward over one period (the authors' flocking "
            "controller), speed capped at max_speed_m_s."
        ),
    )
    accel_step_m_s2: float = Field(
        0.25, gt=0, description="Grid step of the acceleration labels, m/s^2."
    )
    accel_levels: int = Field(
        2, ge=1, le=10, description="Acceleration levels on each side of zero (2: +-0.5 m/s^2)."
    )
    max_speed_m_s: float = Field(
        15.0, gt=0, description="Speed limit; step_m / control_period_s may not exceed it, m/s."
    )
    arena_margin_m: float = Field(
        50.0,
        ge=0,
        description=(
            "Margin of the arena box around the ROI and the take-off area; moves leaving the "
            "arena are invalid, metres."
        ),
    )


class FaultsConfig(_Section):
    """Failures during a mission, seeded (docs/comms.md, "Faults"). A crashed robot stops
    and falls silent; a radio failure leaves it flying, deaf and mute; the others learn of
    either only through their routing tables' hold times and the age of its messages."""

    crash: tuple[tuple[float, int], ...] = Field(
        (),
        description="Crash-stop failures as [[t_s, robot], ...]: from t_s on the robot holds "
        "its position and neither sends nor receives.",
    )
    crash_rate_per_s: float = Field(
        0.0,
        ge=0,
        le=1.0,
        description="Random crash-stop failures: every robot's hazard rate, per second "
        "(exponential times drawn once per run from the seed), 1/s.",
    )
    radio_failure: tuple[tuple[float, int], ...] = Field(
        (),
        description="Radio-only failures as [[t_s, robot], ...]: from t_s the robot flies on "
        "but neither sends nor receives.",
    )
    jam_center_m: tuple[Coordinate, Coordinate] | None = Field(
        None, description="Centre of a jammed disc where no robot can send or receive, metres."
    )
    jam_radius_m: float = Field(0.0, ge=0, le=1e6, description="Radius of the jammed disc, metres.")
    jam_start_s: float = Field(0.0, ge=0, description="When the jamming starts, seconds.")
    jam_end_s: float | None = Field(
        None, ge=0, description="When the jamming ends, seconds (unset: never)."
    )
    gps_error_m: float = Field(
        0.0,
        ge=0,
        le=1e4,
        description="Standard deviation of the position error of the states robots report "
        "(routed comms), per coordinate x, y, metres.",
    )


class SimConfig(_Section):
    """The stage loop.

    Defaults where the paper is silent: 90 s of mission (the default swarm crosses the ROI
    and settles well within it) after a 10 s network warm-up (OLSR needs two HELLO rounds,
    about 2.5 s in ns-3, before the first 1-hop routes exist).
    """

    control_period_s: float = Field(
        1.0, gt=0, description="Time between two stage games, seconds (paper: 1 Hz)."
    )
    duration_s: float = Field(
        90.0,
        gt=0,
        le=MAX_SIM_TIME_S,
        description=(
            "Simulated mission time; at most 1e6 s (11.6 days: the network simulates every "
            "message of it, and every stage is kept in memory), seconds."
        ),
    )
    warmup_s: float = Field(
        10.0,
        ge=0,
        le=MAX_SIM_TIME_S,
        description=(
            "Network time before the first stage (OLSR start-up); at most 1e6 s (the network "
            "simulates every message of it before the first stage), seconds."
        ),
    )
    controller: str = Field(
        "game",
        description=(
            "'game': every robot solves its local graphical game; 'mpc': the game's candidate "
            "decisions played mpc_horizon stages ahead on the run's own models, the best "
            "executed (a centralised reference, docs/mpc.md); or a baseline the mission "
            "offers (centralised states, no game), e.g. the coverage mission's 'lloyd' "
            "(Lloyd/Voronoi coverage)."
        ),
    )
    mpc_horizon: int = Field(
        3,
        ge=1,
        le=20,
        description=(
            "Stages the 'mpc' controller looks ahead (1: the myopic game controller); each "
            "stage then costs about (candidates x horizon) stages."
        ),
    )
    mpc_samples: int = Field(
        2,
        ge=0,
        le=64,
        description=(
            "Candidate profiles the 'mpc' controller draws from the robots' mean-field "
            "marginals, besides the myopic decision and holding positions."
        ),
    )
    global_regret: bool = Field(
        True,
        description=(
            "Measure every robot's stage-game regret (metrics.csv global_regret), from the "
            "solved games' tables; with virtual means on, the games that held a virtual mean "
            "are evaluated a second time with actual states. Also its ex-post regret "
            "(expost_regret: against the states its neighbours reached), one more "
            "evaluation of every true local game."
        ),
    )
    checkpoint_every: int = Field(
        1,
        ge=0,
        le=1_000_000,
        description=(
            "Keep a checkpoint in the run folder every this many stages, so that "
            "`swarmgames run --resume DIR` can continue an interrupted run bit for bit (0: "
            "none; the completed stages are kept in the tables either way)."
        ),
    )
    tables: Literal["auto", "csv", "csv.gz", "parquet"] = Field(
        "auto",
        description=(
            "Format of trajectory, metrics and swarm: 'csv'; 'csv.gz' (compressed); "
            "'parquet' (a Parquet dataset, pip install \"swarmgames[parquet]\"); 'auto': csv "
            "up to 500 000 trajectory rows (robots x stages), then parquet if pyarrow is "
            "installed, else csv.gz."
        ),
    )
    memory_limit_gib: float | None = Field(
        None,
        gt=0,
        le=1e6,
        description="Refuse, before it starts, a run whose estimated peak memory exceeds this "
        "(swarmgames.sim.memory); unset = 80 % of the memory available when it starts, GiB.",
    )
    animation: bool = Field(
        True, description="Write animation.gif of the swarm over the mission's background."
    )
    animation_frames: int = Field(
        60, ge=2, le=1000, description="Maximum number of frames of the animation."
    )
    animation_max_mb: float = Field(
        8.0,
        gt=0,
        le=1000.0,
        description=(
            "Largest animation.gif, MB; a larger one is drawn again with half the frames "
            "(down to 2)."
        ),
    )


#: The ns-3 backend's one PHY rate (``OfdmRate6Mbps`` for data and control), Mbit/s.
NS3_RATE_MBPS = 6.0


#: Fields of ``[comms]`` and the models under which they act: set to anything but their
#: default under another model they would do nothing, so a grid over them would run the
#: same run twice.
_COMMS_FIELDS_OF = {
    "loss_rate": ("routed", "csma"),
    "loss_model": ("routed",),
    "ge_good_to_bad": ("routed",),
    "ge_bad_to_good": ("routed",),
    "ge_loss_bad": ("routed",),
    "hop_delay_s": ("routed",),
    "jitter_s": ("csma", "ns3"),
}


def _check_comms_fields_act(comms: CommsConfig) -> None:
    """Every ``[comms]`` field set away from its default acts under ``comms.model``."""
    defaults = CommsConfig()
    for name, models in _COMMS_FIELDS_OF.items():
        value = getattr(comms, name)
        if comms.model not in models and value != getattr(defaults, name):
            raise ValueError(
                f"comms.{name} has no effect with comms.model = {comms.model!r}: it must keep "
                f"its default {getattr(defaults, name)!r} unless comms.model is "
                f"{' or '.join(map(repr, models))} (got {value!r})"
            )


def _check_ns3_comms(comms: CommsConfig, network: NetworkConfig) -> None:
    """``comms.model = 'ns3'``: the packets need ns-3's nodes, and ns-3 decides the loss."""
    if network.backend != "ns3":
        raise ValueError(
            "comms.model = 'ns3' sends the messages through ns-3: network.backend must be "
            f"'ns3' (got {network.backend!r})"
        )
    if comms.loss_rate != 0:
        raise ValueError(
            "comms.loss_rate must be 0 with comms.model = 'ns3', where ns-3's channel decides "
            f"the loss (got {comms.loss_rate})"
        )
    if comms.loss_model != "iid":
        raise ValueError(
            "comms.loss_model must be 'iid' with comms.model = 'ns3', where ns-3's channel "
            f"decides the loss (got {comms.loss_model!r})"
        )
    if comms.rate_mbps != NS3_RATE_MBPS:
        raise ValueError(
            f"comms.rate_mbps must be {NS3_RATE_MBPS:g} with comms.model = 'ns3', the ns3 "
            f"backend's PHY rate (got {comms.rate_mbps})"
        )


def _check_controller(controller: str, scenario: str) -> None:
    """``sim.controller`` is one of the simulation's controllers or a baseline that mission
    ``scenario`` declares (:attr:`~swarmgames.missions.registry.MissionEntry.baselines`)."""
    from swarmgames.missions.registry import get_mission

    baselines = get_mission(scenario).baselines
    if controller in CONTROLLERS or controller in baselines:
        return
    offered = ", ".join(map(repr, baselines)) or "none"
    raise ValueError(
        f"sim.controller must be {', '.join(map(repr, CONTROLLERS))} or a baseline of mission "
        f"{scenario!r} (it offers: {offered}) (got {controller!r})"
    )


class ScenarioConfig(_Section):
    """A complete scenario: everything a run needs, and nothing it does not.

    The mission's own section is ``mission``: in a scenario file, the table named by
    ``scenario`` (``[coverage]`` for the default mission; :func:`~swarmgames.config.io.
    parse_config` moves it), validated by that mission's section class
    (:func:`swarmgames.missions.get_mission`).

    Examples
    --------
    >>> cfg = ScenarioConfig()
    >>> cfg.scenario, type(cfg.mission).__name__
    ('coverage', 'CoverageConfig')
    >>> cfg.with_overrides({"swarm.n_robots": 20, "coverage.move_cost_db": 0.0}).swarm.n_robots
    20
    """

    name: str = Field(
        "coverage",
        min_length=1,
        max_length=64,
        pattern=NAME_PATTERN,
        description=(
            "Scenario name; also the default run folder name, runs/<name>/: letters, digits, "
            "'_', '.' and '-', not starting with '.' (so it cannot leave runs/ or be hidden)."
        ),
    )
    scenario: str = Field(
        "coverage",
        description=(
            "Mission: a registered mission name (built in: coverage, rendezvous, flocking; "
            "plug-ins through the 'swarmgames.missions' entry points); its parameters are the "
            "table of that name."
        ),
    )
    seed: int = Field(
        0, ge=0, le=2**63 - 1, description="Seed of the run's numpy random Generator."
    )
    swarm: SwarmConfig = Field(default_factory=SwarmConfig)
    network: NetworkConfig = Field(default_factory=NetworkConfig)
    game: GameConfig = Field(default_factory=GameConfig)
    sim: SimConfig = Field(default_factory=SimConfig)
    comms: CommsConfig = Field(default_factory=CommsConfig)
    faults: FaultsConfig = Field(default_factory=FaultsConfig)
    mission: SerializeAsAny[Section] = Field(
        default=None, description="The mission's own section (the table named by scenario)."
    )

    @field_validator("name", mode="before")
    @classmethod
    def _folder_name(cls, value: Any) -> Any:
        # Before the pattern, for a message that says why ("." and ".." leave runs/).
        if isinstance(value, str) and not re.fullmatch(NAME_PATTERN, value):
            raise ValueError(
                "must be a folder name inside runs/: letters, digits, '_', '.' and '-', not "
                f"starting with '.' (got {value!r})"
            )
        return value

    @field_validator("scenario")
    @classmethod
    def _known_mission(cls, name: str) -> str:
        from swarmgames.missions.registry import get_mission

        get_mission(name)  # ConfigError (a ValueError) naming the registered missions
        return name

    @field_validator("mission", mode="before")
    @classmethod
    def _mission_section(cls, value: Any, info) -> Any:
        from swarmgames.missions.registry import get_mission

        name = info.data.get("scenario")
        if name is None:  # the scenario itself was invalid: reported there
            return Section()
        section = get_mission(name).config
        if value is None:
            return section()
        if isinstance(value, section):
            return value
        if isinstance(value, Section):
            raise ValueError(
                f"mission {name!r} takes a {section.__name__} (got {type(value).__name__})"
            )
        return section.model_validate(value)

    @model_validator(mode="after")
    def _cross_field_rules(self) -> ScenarioConfig:
        """Rules that span sections (each section checks its own fields)."""
        self._derive()
        sw, sim = self.swarm, self.sim
        speed = sw.step_m / sim.control_period_s
        if sw.action_set == "headings" and speed > sw.max_speed_m_s * (1 + 1e-12):
            raise ValueError(
                "swarm.step_m / sim.control_period_s must be <= swarm.max_speed_m_s "
                f"(got {sw.step_m} m / {sim.control_period_s} s = {speed:g} m/s > "
                f"{sw.max_speed_m_s} m/s)"
            )
        if sim.duration_s < sim.control_period_s:
            raise ValueError(
                "sim.duration_s must be >= sim.control_period_s "
                f"(got {sim.duration_s} < {sim.control_period_s})"
            )
        stages = sim.duration_s / sim.control_period_s
        if stages > MAX_STAGES:
            raise ValueError(
                f"sim.duration_s / sim.control_period_s must be <= {MAX_STAGES:.0e} stages "
                "(every stage is kept in memory) "
                f"(got {sim.duration_s} s / {sim.control_period_s} s = {stages:.3g})"
            )
        if self.comms.model == "ns3":
            _check_ns3_comms(self.comms, self.network)
        _check_comms_fields_act(self.comms)
        _check_controller(sim.controller, self.scenario)
        if sim.controller == "mpc" and sim.mpc_horizon > 1 and self.network.backend == "ns3":
            raise ValueError(
                "sim.controller = 'mpc' predicts the network by snapshot and restore, which "
                "ns-3 cannot do (it has no simulator snapshot); use network.backend = 'olsr' "
                "(the built-in model of ns-3's OLSR) or sim.mpc_horizon = 1"
            )
        if self.comms.model != "ideal" and self.comms.decide_after_s >= sim.control_period_s:
            raise ValueError(
                "comms.decide_after_s must be < sim.control_period_s (a robot decides within "
                f"its period) (got {self.comms.decide_after_s} >= {sim.control_period_s})"
            )
        for name in ("crash", "radio_failure"):
            for when, robot in getattr(self.faults, name):
                if not (0 <= robot < sw.n_robots) or when < 0:
                    raise ValueError(
                        f"faults.{name}: every [t_s, robot] needs t_s >= 0 and "
                        f"0 <= robot < swarm.n_robots = {sw.n_robots} (got [{when}, {robot}])"
                    )
        if self.faults.jam_radius_m > 0 and self.faults.jam_center_m is None:
            raise ValueError("faults.jam_radius_m > 0 needs faults.jam_center_m (got None)")
        if self.game.solver == "centralised" and self.game.pair_weighting != "sum":
            raise ValueError(
                "game.pair_weighting = 'mean' weights each local game by its size; the "
                "centralised game is one swarm-wide game whose pairs stop at h hops, so it "
                "needs game.pair_weighting = 'sum' (got 'mean')"
            )
        if self.game.solver == "centralised" and sim.controller == "game" and sw.n_robots > 300:
            raise ValueError(
                "game.solver = 'centralised' holds an N^2 A^2 table: swarm.n_robots must be "
                f"<= 300 (got {sw.n_robots})"
            )
        if isinstance(self.mission, Section):
            self.mission.check_scenario(self)  # the mission's rules across sections
        return self

    def _derive(self) -> None:
        """Replace the fields the mission's section derives (:meth:`Section.derive`), once,
        while the configuration is being validated. The replaced sections do not count the
        derived fields as given, so that deriving again (an override, a re-read) agrees."""
        if not isinstance(self.mission, Section):
            return
        for section, values in self.mission.derive(self).items():
            current = getattr(self, section)
            new = current.model_copy(update=values)
            new.__pydantic_fields_set__.difference_update(values)
            self.__dict__[section] = new  # frozen: set while validating only

    def derived_fields(self) -> dict[str, tuple[str, ...]]:
        """The fields derived at validation (:meth:`Section.derive`) by section attribute
        (``"swarm"``, ``"mission"``), which a written-back configuration leaves out.

        Examples
        --------
        >>> ScenarioConfig().derived_fields()
        {}
        """
        if not isinstance(self.mission, Section):
            return {}
        return {section: tuple(values) for section, values in self.mission.derive(self).items()}

    def with_overrides(self, overrides: dict[str, Any]) -> ScenarioConfig:
        """A re-validated copy with fields replaced by dotted path, as ``--set`` does.

        Parameters
        ----------
        overrides : dict
            ``{"section.field": value}``; the paths of ``--set`` (``"seed"``,
            ``"swarm.n_robots"``, ``"network.radio.tx_power_dbm"``, the mission's table by
            its name: ``"coverage.move_cost_db"``). Values are Python values, checked as
            strictly as a scenario file's.

        Returns
        -------
        ScenarioConfig
            A new configuration; this one is unchanged (configurations are frozen).

        Raises
        ------
        ConfigError
            An unknown path, or a value the schema rejects (one line per problem).
        """
        from swarmgames.config.io import apply_overrides

        return apply_overrides(self, overrides)
