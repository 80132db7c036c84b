"""Exception hierarchy of swarmgames.

Every exception subclasses a built-in so that callers can catch it either by the specific
swarmgames type or by the built-in they already expect (python-control's
``ControlDimension(ValueError)`` pattern). Errors that carry data keep it as attributes.
"""

from __future__ import annotations

__all__ = [
    "BackendUnavailableError",
    "ChannelOverloadWarning",
    "ConfigError",
    "InputDataError",
    "Ns3CrashError",
    "OutputWriteError",
    "PayoffError",
    "RunFolderError",
    "SwarmgamesError",
]


class SwarmgamesError(Exception):
    """Base class of every error raised on purpose by swarmgames."""


class ConfigError(SwarmgamesError, ValueError):
    """A configuration value or file is invalid.

    Parameters
    ----------
    message : str
        Human-readable description naming the field, the rule and the value.
    errors : list of str, optional
        One line per problem when several were found at once.
    """

    def __init__(self, message: str, errors: list[str] | None = None) -> None:
        super().__init__(message)
        self.errors = list(errors) if errors else [message]


class InputDataError(SwarmgamesError, ValueError):
    """An input data file (positions trace, ...) is malformed; the message names the row."""


class RunFolderError(SwarmgamesError, FileExistsError):
    """The output folder cannot be used: it exists and is not empty and ``force`` was not
    given, it is a file, or it cannot be created or written into."""


class OutputWriteError(SwarmgamesError, OSError):
    """An output file could not be written (disk full, permission, ...); the message names
    the file and the system's reason, and the file is left absent or as it was."""


class PayoffError(SwarmgamesError, ValueError):
    """A potential gave a non-finite payoff (a mission's bug, or states out of its range);
    the message names the robot, its local game and the action, and the run adds the mission
    and the stage."""


class BackendUnavailableError(SwarmgamesError, ImportError):
    """An optional backend (for example ns-3) is not installed; the message says how to get it."""


class Ns3CrashError(SwarmgamesError, RuntimeError):
    """The ns-3 process stopped: an ``NS_ASSERT`` or ``NS_FATAL_ERROR`` in ns-3, or a crash.

    ns-3 runs in a child process of its own (:mod:`swarmgames.network.ns3_process`), so the
    caller survives and keeps what it completed. The message is one line quoting ns-3's
    reason, with the ns-3 run number and the simulated time.

    Attributes
    ----------
    reason : str
        ns-3's own line (``NS_ASSERT failed, cond=...``), or how the process ended.
    run : int or None
        The ns-3 run number (``RngSeedManager::SetRun``) of the scenario that was running.
    time : float or None
        Simulated time of the failure in the caller's clock, seconds (ns-3's time stamp plus
        the scenario's start time), or the time ns-3 was asked to reach if ns-3 gave none.
    exit_code : int
        The process's exit status (negative: killed by that signal).
    """

    def __init__(
        self, message: str, reason: str, run: int | None, time: float | None, exit_code: int
    ) -> None:
        super().__init__(message)
        self.reason, self.run, self.time, self.exit_code = reason, run, time, exit_code


class ChannelOverloadWarning(UserWarning):
    """The messages of a stage need more airtime than the decision window holds: some cannot
    arrive by the decision, whatever the channel access (docs/comms.md, "Channel load")."""
