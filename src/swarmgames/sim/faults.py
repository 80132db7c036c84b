"""Failures during a mission: crashes, dead radios, a jammed region, GPS error.

A :class:`Faults` schedule says, at every stage time, which robots are *alive* (a crashed
robot holds its position for the rest of the run and never decides again) and which have a
working *radio* (alive, radio not failed, outside the jammed disc while the jamming lasts).
A robot without a radio sends and receives nothing: the network sees it out of everyone's
range (:meth:`Faults.network_positions`), so its links break and its neighbours' routing
tables forget it only after OLSR's hold times, exactly as a silent node is forgotten; the
communication layer neither delivers its messages nor gives it any. No other robot is told:
each learns of a failure only through its own table and the age of the messages it holds.

Random crash times are exponential draws, one per robot, made once per run from the seeded
generator; scheduled failures come from the configuration.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swarmgames.arrays import freeze_fields

__all__ = ["FAR_AWAY_M", "Faults"]

#: Where the network sees a robot without a radio: far beyond any radio range, each such
#: robot 10 km from the next so that no two of them link either, metres.
FAR_AWAY_M = 1.0e8


@dataclass(frozen=True, eq=False)
class Faults:
    """The failure schedule of one run.

    Parameters
    ----------
    crash_s, radio_s : ndarray, shape (N,)
        Each robot's crash time and radio-failure time, seconds (``inf``: never).
    jam_center_m : (float, float) or None
    jam_radius_m, jam_start_s, jam_end_s : float
        The jammed disc and when it is jammed (``jam_end_s`` may be ``inf``).
    """

    crash_s: np.ndarray
    radio_s: np.ndarray
    jam_center_m: tuple[float, float] | None = None
    jam_radius_m: float = 0.0
    jam_start_s: float = 0.0
    jam_end_s: float = np.inf

    def __post_init__(self) -> None:
        freeze_fields(self)

    @classmethod
    def none(cls, n_robots: int) -> Faults:
        """No failure at all."""
        never = np.full(n_robots, np.inf)
        return cls(never, never.copy())

    @classmethod
    def from_config(cls, faults, n_robots: int, rng: np.random.Generator) -> Faults:
        """The schedule a :class:`~swarmgames.config.FaultsConfig` describes; random crashes
        drawn from ``rng`` (one exponential per robot, only when the rate is > 0)."""
        crash = np.full(n_robots, np.inf)
        if faults.crash_rate_per_s > 0:
            crash = rng.exponential(1.0 / faults.crash_rate_per_s, n_robots)
        for when, robot in faults.crash:
            crash[robot] = min(crash[robot], when)
        radio = np.full(n_robots, np.inf)
        for when, robot in faults.radio_failure:
            radio[robot] = min(radio[robot], when)
        jam = faults.jam_center_m if faults.jam_radius_m > 0 else None
        end = np.inf if faults.jam_end_s is None else faults.jam_end_s
        return cls(crash, radio, jam, faults.jam_radius_m, faults.jam_start_s, end)

    @property
    def any(self) -> bool:
        """Whether anything can fail."""
        return bool(
            np.isfinite(self.crash_s).any()
            or np.isfinite(self.radio_s).any()
            or self.jam_center_m is not None
        )

    def alive(self, t: float) -> np.ndarray:
        """Robots that have not crashed by ``t``, shape (N,)."""
        return self.crash_s > t

    def radio(self, t: float, positions: np.ndarray) -> np.ndarray:
        """Robots whose radio works at ``t``: alive, not failed, not in the jammed disc."""
        ok = self.alive(t) & (self.radio_s > t)
        if self.jam_center_m is not None and self.jam_start_s <= t < self.jam_end_s:
            d = np.hypot(*(np.asarray(positions)[:, :2] - self.jam_center_m).T)
            ok &= d > self.jam_radius_m
        return ok

    def network_positions(self, positions: np.ndarray, radio: np.ndarray) -> np.ndarray:
        """The positions the network sees: robots without a radio far out of range."""
        pos = np.array(positions[:, :3], dtype=float)
        off = np.flatnonzero(~radio)
        pos[off, 0] = FAR_AWAY_M + 1.0e4 * off
        pos[off, 1] = FAR_AWAY_M
        return pos
