"""``check_mission``: the conformance test a mission plug-in author runs.

In the spirit of PettingZoo's ``parallel_api_test`` and scikit-learn's ``check_estimator``:
one call exercises everything the simulation will ask of a mission, on a small swarm, and
reports every problem it finds in one :class:`MissionCheckError` (a ``ValueError``) whose
lines say what is wrong and what was expected. It returns nothing when the mission conforms.

What is checked
---------------
* the attributes of :class:`~swarmgames.missions.protocol.Mission`: ``name`` (a non-empty
  string), ``state_dim`` (an integer >= 3), ``potentials`` and ``action_model``;
* ``initial_states``: shape ``(N, state_dim)``, finite, reproducible from a seeded Generator,
  drawing nothing from numpy's global random state;
* the action model at those states (:func:`~swarmgames.game.checks.check_action_model`);
* the potentials' declared capabilities (:func:`~swarmgames.game.capabilities.
  capabilities_of`: a :class:`~swarmgames.game.capabilities.PotentialCapabilities` whose
  declared forms have their methods) and, when declared, the neighbourhood term: shape
  ``(B, A)``, real, finite at the owners' valid actions, the same for a sub-batch;
* the potentials on the local games of a line of robots, with and without virtual means
  (:func:`~swarmgames.game.checks.check_potentials`: shapes, finite values, games that do not
  depend on each other), before and after one stage of random valid actions;
* time: the potentials on the same local games at two stage times (``batch.t``), finite and of
  the right shape at both;
* ``swarm_metrics(states, previous, t)``: a mapping of names to finite real numbers, the same
  names at every stage, none taken by the loop's own columns;
* the metrics hooks' signatures: ``swarm_metrics`` and ``robot_metrics`` take the stage time
  ``t``; one written without it is one line naming the hook and the signature expected;
* the optional hooks, where present: ``robot_metrics`` (finite ``(N,)`` arrays), ``summary``
  (JSON-serialisable values), ``draw`` (runs on a matplotlib Axes), ``extent`` (a box with
  ``xmin < xmax`` and ``ymin < ymax``), ``moves_undone`` (None, or the first swarm metric
  with each robot's move undone in turn, equal to calling ``swarm_metrics`` for each) and
  ``baselines`` (named callables that return one valid action index per robot and leave the
  states they are given unchanged).
"""

from __future__ import annotations

import inspect
import json
import numbers
from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from swarmgames.game.actions import action_mask_of
from swarmgames.game.capabilities import capabilities_of
from swarmgames.game.checks import check_action_model, check_potentials
from swarmgames.game.local import local_games
from swarmgames.missions.protocol import RESERVED_COLUMNS
from swarmgames.names import CONTROLLERS, VIRTUAL_MEANS
from swarmgames.topology import TopologySnapshot

__all__ = ["MissionCheckError", "check_mission"]

#: Two stage times (seconds) at which the time-dependent parts are exercised: the stages of
#: the metrics check and the batches of the potentials' time check.
_TIMES = (10.0, 250.0)

#: The metrics hooks, with their arguments as the loop passes them.
_METRICS_HOOKS = {
    "swarm_metrics": "swarm_metrics(states, previous, t)",
    "robot_metrics": "robot_metrics(states, t)",
}


class MissionCheckError(ValueError):
    """A mission does not conform; ``problems`` lists every finding."""

    def __init__(self, name: str, problems: list[str]) -> None:
        self.problems = list(problems)
        lines = "\n  ".join(self.problems)
        super().__init__(
            f"mission {name!r} does not conform ({len(problems)} problems):\n  {lines}"
        )


def _global_random_state() -> tuple[bytes, int, int, float]:
    """numpy's global Mersenne Twister state: its key, position and cached Gaussian.

    A draw always moves the position, so comparing the whole state catches a draw of any
    size, where the key alone changes only when the generator refills its block.
    """
    _, key, pos, has_gauss, cached = np.random.get_state()  # noqa: NPY002 - read, not drawn
    return key.tobytes(), int(pos), int(has_gauss), float(cached)


def _line_snapshot(n: int) -> TopologySnapshot:
    """Robots 0..n-1 on a line, each linked to the next: BFS hop counts."""
    idx = np.arange(n)
    return TopologySnapshot.from_hop_matrix(0.0, np.abs(idx[:, None] - idx[None, :]))


def _metric_problems(where: str, out: Any, n: int | None, keys=None) -> list[str]:
    if not isinstance(out, dict):
        return [f"{where} must return a dict of name -> value (got {type(out).__name__})"]
    found = []
    for name, val in out.items():
        if not (isinstance(name, str) and name):
            found.append(f"{where}: metric names must be non-empty strings (got {name!r})")
            continue
        if name in RESERVED_COLUMNS:
            found.append(f"{where}: {name!r} is a column the simulation writes itself")
        if n is None:
            ok = isinstance(val, numbers.Real) and not isinstance(val, bool)
            if not ok or not np.isfinite(float(val)):
                found.append(f"{where}[{name!r}] must be a finite real number (got {val!r})")
        else:
            arr = np.asarray(val)
            if arr.shape != (n,) or not np.issubdtype(arr.dtype, np.number):
                found.append(f"{where}[{name!r}] must be a numeric array of shape ({n},)")
            elif not np.all(np.isfinite(arr)):
                found.append(f"{where}[{name!r}] must be finite")
    if keys is not None and set(out) != set(keys):
        found.append(f"{where} must return the same names at every stage ({sorted(keys)})")
    return found


def check_mission(mission: Any, n_robots: int = 4, seed: int = 0) -> None:
    """Check that ``mission`` follows the :class:`~swarmgames.missions.protocol.Mission`
    protocol.

    Parameters
    ----------
    mission : Mission
        The mission object (for a registered one: ``get_mission(name).build(config)``).
    n_robots : int, default 4
        Size of the test swarm, >= 2.
    seed : int, default 0
        Seed of the test's random draws.

    Raises
    ------
    MissionCheckError
        Every problem found, one per line.

    Examples
    --------
    >>> from swarmgames.config import ScenarioConfig
    >>> from swarmgames.missions import get_mission
    >>> check_mission(get_mission("coverage").build(ScenarioConfig()))
    """
    if isinstance(n_robots, bool) or not isinstance(n_robots, int) or n_robots < 2:
        raise ValueError(f"n_robots must be an integer >= 2 (got {n_robots!r})")
    name = getattr(mission, "name", None)
    label = name if isinstance(name, str) else type(mission).__name__
    problems: list[str] = []

    def fail(msg: str) -> None:
        raise MissionCheckError(label, [*problems, msg])

    if not (isinstance(name, str) and name):
        problems.append(f"name must be a non-empty string (got {name!r})")
    for attr in ("potentials", "action_model", "state_dim", "initial_states", "swarm_metrics"):
        if not hasattr(mission, attr):
            problems.append(f"missing required attribute {attr!r}")
    if problems:
        raise MissionCheckError(label, problems)
    dim = mission.state_dim
    if isinstance(dim, bool) or not isinstance(dim, (int, np.integer)) or dim < 3:
        fail(f"state_dim must be an integer >= 3 (x, y, z first) (got {dim!r})")

    # initial_states: shape, finite, seeded, no global random state.
    before = _global_random_state()
    try:
        s0 = np.asarray(mission.initial_states(n_robots, np.random.default_rng(seed)), float)
        again = np.asarray(mission.initial_states(n_robots, np.random.default_rng(seed)), float)
    except Exception as exc:
        fail(f"initial_states(n_robots, rng) raised {type(exc).__name__}: {exc}")
    if _global_random_state() != before:
        problems.append("initial_states draws from numpy's global random state; use the rng")
    if s0.shape != (n_robots, dim):
        fail(f"initial_states must return shape ({n_robots}, {dim}) (got {s0.shape})")
    if not np.all(np.isfinite(s0)):
        fail("initial_states returned non-finite states")
    if not np.array_equal(s0, again):
        problems.append("initial_states is not reproducible: the same seed gave other states")

    # Action model and potentials on real local games.
    model = mission.action_model
    try:
        check_action_model(model, s0)
    except ValueError as exc:
        fail(f"action_model: {exc}")
    rng = np.random.default_rng(seed + 1)
    snap = _line_snapshot(n_robots)
    nxt = np.asarray(model.apply(s0))
    valid = action_mask_of(model, s0)
    pick = np.array([rng.choice(np.flatnonzero(v)) for v in valid])
    s1 = nxt[np.arange(n_robots), pick]
    declared = _capability_problems(mission.potentials, snap, (s0, s1), model)
    if declared:  # the potentials cannot be evaluated without their declaration
        raise MissionCheckError(label, problems + declared)
    found_before = len(problems)
    for states, when in ((s0, "at the initial states"), (s1, "after one stage")):
        for vm in VIRTUAL_MEANS:
            batch = local_games(snap, 1, states, model, virtual_mean=vm)
            try:
                check_potentials(mission.potentials, batch)
            except Exception as exc:
                problems.append(
                    f"potentials {when} (virtual_mean = {vm!r}): {type(exc).__name__}: {exc}"
                )
                break

    if len(problems) == found_before:  # time adds nothing to potentials already failing
        problems += _time_problems(mission.potentials, local_games(snap, 1, s1, model))

    # Metrics.
    old = _signature_problems(mission, s0)
    problems += list(old.values())
    keys = None
    stages = ((s0, None, _TIMES[0], "first stage"), (s1, s0, _TIMES[1], "second stage"))
    if "swarm_metrics" in old:  # reported once above, not once per call
        stages = ()
    for states, prev, t, when in stages:
        try:
            out = mission.swarm_metrics(states, prev, t)
        except Exception as exc:
            problems.append(f"swarm_metrics at the {when} raised {type(exc).__name__}: {exc}")
            break
        problems += _metric_problems(f"swarm_metrics ({when})", out, None, keys)
        keys = list(out) if isinstance(out, dict) else keys
    # summary reads the swarm_metrics columns: unknown when that hook could not be called.
    skip = set(old) | ({"summary"} if "swarm_metrics" in old else set())
    problems += _optional_hooks(mission, s1, keys or [], skip=skip)
    if hasattr(mission, "moves_undone") and keys and "swarm_metrics" not in old:
        problems += _moves_undone_problems(mission, s1, s0, keys[0])
    if problems:
        raise MissionCheckError(label, problems)


def _time_problems(potentials: Any, batch: Any) -> list[str]:
    """The potentials on ``batch`` at each of two stage times: finite, of the right shape.

    A mission with time-varying data (a moving target) reads ``batch.t``; one that does not
    gives the same values at both times, which is fine too.
    """
    found: list[str] = []
    for t in _TIMES:
        try:
            check_potentials(potentials, replace(batch, t=t))
        except Exception as exc:
            found.append(f"potentials at stage time t = {t:g} s: {type(exc).__name__}: {exc}")
    return found


def _signature_problems(mission: Any, states: np.ndarray) -> dict[str, str]:
    """The metrics hooks that cannot be called with the stage time: hook -> one line."""
    found: dict[str, str] = {}
    args = {"swarm_metrics": (states, None, _TIMES[0]), "robot_metrics": (states, _TIMES[0])}
    for hook, expected in _METRICS_HOOKS.items():
        if not hasattr(mission, hook):
            continue
        try:
            inspect.signature(getattr(mission, hook)).bind(*args[hook])
        except TypeError:
            found[hook] = (
                f"{hook} must take the stage time: {expected}, t the stage time in seconds "
                f"(got {hook}{inspect.signature(getattr(mission, hook))})"
            )
        except ValueError:  # no signature to read (a builtin): the call itself will tell
            continue
    return found


def _capability_problems(potentials: Any, snap, states_seq, model) -> list[str]:
    """The potentials' declared capabilities (:func:`~swarmgames.game.capabilities.
    capabilities_of`) and, when they declare a neighbourhood term, its output on the local
    games of ``snap`` at each of ``states_seq``: shape (B, A), real, finite at the owners'
    valid actions, and the same rows for a sub-batch (no game depends on another)."""
    try:
        caps = capabilities_of(potentials)
    except TypeError as exc:
        return [str(exc)]
    if not caps.neighbourhood:
        return []
    for states in states_seq:
        batch = local_games(snap, 1, states, model)
        want = (batch.n_games, batch.n_actions)
        try:
            psi = np.asarray(potentials.neighbourhood(batch))
            half = np.arange(batch.n_games)[::2]
            part = np.asarray(potentials.neighbourhood(batch.select(half)))
        except Exception as exc:
            return [f"potentials.neighbourhood(batch) raised {type(exc).__name__}: {exc}"]
        if psi.shape != want:
            return [f"potentials.neighbourhood must return shape {want} (got {psi.shape})"]
        if not (np.issubdtype(psi.dtype, np.floating) or np.issubdtype(psi.dtype, np.integer)):
            return [f"potentials.neighbourhood must return real numbers (got dtype {psi.dtype})"]
        valid = np.asarray(batch.action_mask)[:, 0]
        if not np.all(np.isfinite(psi[valid])):
            return ["potentials.neighbourhood returned non-finite values at valid actions"]
        ok = valid[half]
        if part.shape != (half.size, want[1]) or not np.allclose(
            part[ok], psi[half][ok], rtol=1e-9, atol=1e-12
        ):
            return [
                "potentials.neighbourhood of a game depends on the other games of the batch: "
                "a sub-batch gives different values"
            ]
    return []


def _optional_hooks(mission: Any, states: np.ndarray, keys: list[str], skip: set[str]) -> list[str]:
    found: list[str] = []
    n = states.shape[0]
    if hasattr(mission, "robot_metrics") and "robot_metrics" not in skip:
        try:
            out = mission.robot_metrics(states, _TIMES[1])
            found += _metric_problems("robot_metrics", out, n)
        except Exception as exc:
            found.append(f"robot_metrics raised {type(exc).__name__}: {exc}")
    if hasattr(mission, "summary") and "summary" not in skip:
        times = np.array([0.0, 1.0])
        swarm = {k: np.zeros(2) for k in ("mean_payoff", *keys)}
        try:
            out = mission.summary(times, swarm)
            if not isinstance(out, dict):
                found.append(f"summary must return a dict (got {type(out).__name__})")
            else:
                json.dumps(out, allow_nan=False)
        except (TypeError, ValueError) as exc:
            found.append(f"summary must return JSON-serialisable values: {exc}")
        except Exception as exc:
            found.append(f"summary raised {type(exc).__name__}: {exc}")
    if hasattr(mission, "draw"):
        from matplotlib.figure import Figure

        try:
            mission.draw(Figure().subplots())
        except Exception as exc:
            found.append(f"draw(ax) raised {type(exc).__name__}: {exc}")
    if hasattr(mission, "extent"):
        try:
            box = np.asarray(mission.extent(), dtype=float)
            if (
                box.shape != (4,)
                or not np.all(np.isfinite(box))
                or not (box[0] < box[1] and box[2] < box[3])
            ):
                found.append(f"extent() must be (xmin, xmax, ymin, ymax), finite (got {box})")
        except Exception as exc:
            found.append(f"extent() raised {type(exc).__name__}: {exc}")
    if hasattr(mission, "baselines"):
        found += _baseline_problems(mission, states)
    return found


def _moves_undone_problems(mission: Any, states, previous, name: str) -> list[str]:
    """The ``moves_undone`` hook: None, or ``swarm_metrics``' first value ``name`` with each
    robot's move undone in turn, (N,), equal to the N calls it stands for."""
    t = _TIMES[1]
    try:
        out = mission.moves_undone(states, previous, t)
    except Exception as exc:
        return [f"moves_undone raised {type(exc).__name__}: {exc}"]
    if out is None:
        return []
    out = np.asarray(out)
    n = states.shape[0]
    if out.shape != (n,):
        return [f"moves_undone must return shape ({n},) or None (got {out.shape})"]
    want = np.empty(n)
    for i in range(n):
        undone = np.array(states, dtype=float)
        undone[i] = previous[i]
        want[i] = float(mission.swarm_metrics(undone, previous, t)[name])
    if not np.allclose(out, want, rtol=1e-9, atol=1e-9):
        i = int(np.argmax(np.abs(out - want)))
        return [
            f"moves_undone must equal swarm_metrics' {name!r} with each robot's move undone: "
            f"robot {i} gives {out[i]!r}, swarm_metrics {want[i]!r}"
        ]
    return []


def _baseline_problems(mission: Any, states: np.ndarray) -> list[str]:
    """The ``baselines`` hook: a mapping of identifiers (not the simulation's own controller
    names) to callables that return one valid action index per robot, ``(N,)`` integers, at
    ``states`` without changing them."""
    offered = mission.baselines
    if not isinstance(offered, Mapping):
        return [f"baselines must be a mapping of name -> callable (got {type(offered).__name__})"]
    found: list[str] = []
    n = states.shape[0]
    valid = action_mask_of(mission.action_model, states)
    for name, baseline in offered.items():
        where = f"baselines[{name!r}]"
        if not (isinstance(name, str) and name.isidentifier()) or name in CONTROLLERS:
            found.append(
                f"baseline names must be Python identifiers, none of them "
                f"{' or '.join(map(repr, CONTROLLERS))} (got {name!r})"
            )
            continue
        if not callable(baseline):
            found.append(f"{where} must be callable (got {type(baseline).__name__})")
            continue
        given = states.copy()
        try:
            actions = np.asarray(baseline(given))
        except Exception as exc:
            found.append(f"{where}(states) raised {type(exc).__name__}: {exc}")
            continue
        if not np.array_equal(given, states):
            found.append(f"{where}(states) changed the states it was given")
        if actions.shape != (n,) or not np.issubdtype(actions.dtype, np.integer):
            found.append(
                f"{where}(states) must return an integer array of shape ({n},) "
                f"(got {actions.dtype} {actions.shape})"
            )
        elif np.any(actions < 0) or np.any(actions >= valid.shape[1]):
            found.append(
                f"{where}(states) must return action indices in [0, {valid.shape[1]}) "
                f"(got {actions.tolist()})"
            )
        elif not valid[np.arange(n), actions].all():
            found.append(f"{where}(states) returned actions the action model does not allow")
    return found
