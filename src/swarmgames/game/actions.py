"""Discrete action sets: an action maps a robot's state to its next state.

The engine only needs two vectorised operations from an action model (the
:class:`ActionModel` protocol): ``apply`` gives the next state for every action at once and the
optional ``valid`` says which actions are allowed in a state (heterogeneous action sets, for
example moves that would leave a bounding box). :class:`DisplacementActions` is a generic
model, "stay" plus fixed displacement vectors, enough for the paper's grid-free UAV moves.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, section II.B: A_i, the discrete action set.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["ActionModel", "DisplacementActions", "action_mask_of"]


@runtime_checkable
class ActionModel(Protocol):
    """What the engine needs from a discrete action set.

    Attributes
    ----------
    n_actions : int
        A, the number of actions (>= 1).

    Methods
    -------
    apply(states)
        ``(..., D)`` states to ``(..., A, D)`` next states, one per action.
    valid(states), optional
        ``(..., D)`` states to a ``(..., A)`` boolean mask of allowed actions. Without it
        every action is allowed.
    """

    n_actions: int

    def apply(self, states: np.ndarray) -> np.ndarray: ...


def action_mask_of(model: ActionModel, states: np.ndarray) -> np.ndarray:
    """Allowed actions ``(..., A)`` of ``model`` in ``states`` ``(..., D)``; all true when the
    model has no ``valid`` method."""
    states = np.asarray(states, dtype=float)
    shape = (*states.shape[:-1], int(model.n_actions))
    valid = getattr(model, "valid", None)
    if valid is None:
        return np.ones(shape, dtype=bool)
    out = np.asarray(valid(states), dtype=bool)
    if out.shape != shape:
        raise ValueError(f"action model valid() must return shape {shape} (got {out.shape})")
    return out


@dataclass(frozen=True, eq=False)
class DisplacementActions:
    """Actions that add a fixed displacement to the state: ``s' = s + displacements[a]``.

    Parameters
    ----------
    displacements : array_like, shape (A, D)
        One displacement vector per action, in state units (metres for positions).
    lower, upper : array_like, shape (D,), optional
        Bounding box: an action is valid only if the next state stays inside
        ``lower <= s' <= upper`` (component-wise). "Stay" (a zero displacement) is always
        valid so that no robot is ever left without an action.

    Examples
    --------
    >>> import numpy as np
    >>> m = DisplacementActions.headings(step=10.0, n_headings=4)
    >>> m.n_actions
    5
    >>> np.round(m.apply(np.zeros(2)), 6).tolist()[1]
    [10.0, 0.0]
    """

    displacements: np.ndarray
    lower: np.ndarray | None = None
    upper: np.ndarray | None = None

    def __post_init__(self) -> None:
        disp = np.array(self.displacements, dtype=float, copy=True)
        if disp.ndim != 2 or disp.shape[0] < 1:
            raise ValueError(f"displacements must have shape (A, D) with A >= 1 (got {disp.shape})")
        if not np.all(np.isfinite(disp)):
            raise ValueError("displacements must be finite")
        disp.setflags(write=False)
        object.__setattr__(self, "displacements", disp)
        for name in ("lower", "upper"):
            val = getattr(self, name)
            if val is not None:
                arr = np.array(val, dtype=float, copy=True).reshape(-1)
                if arr.shape != (disp.shape[1],):
                    raise ValueError(f"{name} must have shape ({disp.shape[1]},) (got {arr.shape})")
                arr.setflags(write=False)
                object.__setattr__(self, name, arr)

    @classmethod
    def headings(
        cls,
        step: float,
        n_headings: int = 8,
        *,
        dim: int = 2,
        stay: bool = True,
        lower=None,
        upper=None,
    ) -> DisplacementActions:
        """ "Stay" plus ``n_headings`` moves of length ``step`` at evenly spaced headings in the
        x-y plane (heading 0 along +x, counter-clockwise); other state components unchanged.

        Parameters
        ----------
        step : float
            Move length, > 0 (metres).
        n_headings : int
            Number of headings, >= 1.
        dim : int
            State size D, >= 2 (the move acts on the first two components).
        stay : bool
            Include the zero displacement as action 0.
        """
        if not step > 0:
            raise ValueError(f"step must be > 0 (got {step})")
        if n_headings < 1:
            raise ValueError(f"n_headings must be >= 1 (got {n_headings})")
        if dim < 2:
            raise ValueError(f"dim must be >= 2 (got {dim})")
        ang = 2.0 * np.pi * np.arange(n_headings) / n_headings
        moves = np.zeros((n_headings, dim))
        moves[:, 0] = step * np.cos(ang)
        moves[:, 1] = step * np.sin(ang)
        moves[np.abs(moves) < 1e-12] = 0.0  # exact zeros for axis-aligned headings
        if stay:
            moves = np.vstack([np.zeros((1, dim)), moves])
        return cls(moves, lower, upper)

    @property
    def n_actions(self) -> int:
        """A, the number of actions."""
        return int(self.displacements.shape[0])

    def apply(self, states: np.ndarray) -> np.ndarray:
        """Next states ``(..., A, D)`` of ``states`` ``(..., D)``."""
        states = np.asarray(states, dtype=float)
        return states[..., None, :] + self.displacements

    def valid(self, states: np.ndarray) -> np.ndarray:
        """Allowed actions ``(..., A)``: next state inside the box, or a zero displacement."""
        nxt = self.apply(states)
        ok = np.ones(nxt.shape[:-1], dtype=bool)
        if self.lower is not None:
            ok &= np.all(nxt >= self.lower, axis=-1)
        if self.upper is not None:
            ok &= np.all(nxt <= self.upper, axis=-1)
        return ok | np.all(self.displacements == 0, axis=-1)
