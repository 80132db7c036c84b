"""Peak memory of one stage, predicted from its sizes before anything is allocated.

A stage (:func:`~swarmgames.game.stage.solve`) holds at once, for its largest batch of
local games (:func:`~swarmgames.game.stage.size_groups`: at most ``max_pair_elems`` pairwise
entries, or one game when a single game is larger):

* the pairwise table, ``B K² A²`` entries in the solver's dtype; or, when the solver computes
  the tables on demand (``pair_on_demand``), the tables of one chunk of games (at least 8
  games, or :data:`~swarmgames.game.meanfield.SOURCE_CHUNK_ELEMS` entries) and the batch's
  rows of them at a profile, ``B K² A`` entries, which then bound the batch;
* the largest working blocks: the unary integral's (before the pairwise table exists), the
  pairwise potentials' (beside it), the measurement's gathers of it (beside it) or the
  owners' rows of the global and ex-post regret (beside a table); the mission says how much
  its potentials need and keep (``unary_bytes``, ``pair_work_bytes``,
  ``owner_unary_bytes``);
* for the global regret, every robot's owner row until the joint action is known,
  ``N K A²`` entries;
* the centralised game (one game of ``(N A)²`` entries, built through the dense
  ``(1, N, N, A, A)`` pairwise form, about 20 bytes per entry);
* the inboxes and the batch's states, ``N K`` and ``B K A`` rows of ``D`` values.

Each part is an upper estimate of what the code allocates; ``tests/sim/test_memory.py``
checks the total against measured peaks (tracemalloc) of stages from 7 to 150 robots.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["GIB", "MemoryEstimate", "stage_memory"]

#: Bytes in a gibibyte.
GIB = float(2**30)

#: Bytes per ``B K² A`` entry of the measurement's gathers of the pairwise table and of the
#: evaluation's validity masks (five int64/float64 arrays, one float64 and one bool mask).
_GATHER_BYTES = 57.0

#: Bytes per ``B K² A`` entry of the measurement of games that share one held table: the rows
#: at a profile, gathered by one compiled pass (float64), and numpy's sum over them.
_HELD_ROW_BYTES = 16.0


@dataclass(frozen=True)
class MemoryEstimate:
    """Predicted peak memory, by part.

    Parameters
    ----------
    parts : tuple of (str, float)
        ``(what, bytes)`` of every part, largest first.
    n_vars : int
        K, the neighbourhood size the estimate assumed.
    batch_games : int
        B, the local games of the largest batch.

    Examples
    --------
    >>> est = stage_memory(300, 300, 9)
    >>> est.batch_games, round(est.total_gib, 2)
    (3, 0.35)
    """

    parts: tuple[tuple[str, float], ...]
    n_vars: int
    batch_games: int

    @property
    def total_bytes(self) -> float:
        """Sum of the parts, bytes."""
        return float(sum(b for _, b in self.parts))

    @property
    def total_gib(self) -> float:
        """Sum of the parts, GiB."""
        return self.total_bytes / GIB

    def largest(self) -> tuple[str, float]:
        """The largest part, ``(what, bytes)``."""
        return self.parts[0]

    def with_part(self, what: str, nbytes: float) -> MemoryEstimate:
        """A copy with one more part."""
        parts = sorted((*self.parts, (what, float(nbytes))), key=lambda p: -p[1])
        return MemoryEstimate(tuple(parts), self.n_vars, self.batch_games)

    def describe(self, n: int = 3) -> str:
        """``"1.2 GiB (pairwise tables 0.8 GiB, ...)"``: the total and the ``n`` largest
        parts."""
        top = ", ".join(f"{w} {b / GIB:.2g} GiB" for w, b in self.parts[:n] if b > 0)
        return f"{self.total_gib:.3g} GiB ({top})"


def stage_memory(
    n_robots: int,
    n_vars: int,
    n_actions: int,
    *,
    state_dim: int = 3,
    itemsize: int = 8,
    global_regret: bool = True,
    centralised: bool = False,
    unary_bytes: float = 0.0,
    pair_work_bytes: float = 0.0,
    owner_unary_bytes: float = 0.0,
    max_pair_elems: int | None = None,
    pair_on_demand: bool = False,
    held_sharing: int | None = None,
) -> MemoryEstimate:
    """Predicted peak memory of one stage of ``n_robots`` local games.

    Parameters
    ----------
    n_robots : int
        N.
    n_vars : int
        K, the padded neighbourhood size (owner included) of the largest games, <= N.
    n_actions : int
        A.
    state_dim : int, default 3
        D.
    itemsize : int, default 8
        Bytes of one payoff entry (``game.dtype``: 8 for float64, 4 for float32).
    global_regret : bool, default True
        The stage keeps every owner's row for the global regret.
    centralised : bool, default False
        One swarm-wide game is solved (then every robot's true local game is measured).
    unary_bytes, pair_work_bytes : float, default 0
        The potentials' working memory for one batch, bytes: of the unary (the coverage
        integral's chunks) and beside the pairwise table (the crowding penalty's blocks).
    owner_unary_bytes : float, default 0
        The potentials' working memory for the owners' rows of one batch (the ex-post and
        global regret's ``owner_unary``), which run beside that batch's pairwise table.
    max_pair_elems : int, optional
        The stage's batch budget (default :data:`~swarmgames.game.stage.MAX_PAIR_ELEMS`).
    pair_on_demand : bool, default False
        The solver computes the pairwise tables per chunk of games
        (``pairs_on_demand`` of the solver's capabilities).
    held_sharing : int, optional
        The smallest game (K A entries) whose equal copies in a batch share one held table
        (``held_sharing_min`` of the solver's capabilities). When every game holds every robot
        (K = N) and is this large, its games are equal and batched by their one table
        (:func:`~swarmgames.game.stage.size_groups`), so the estimate is the larger of a
        batch of distinct games and one of equal games (one table, its weighted copy and
        the rows of every game at a profile).

    Returns
    -------
    MemoryEstimate
    """
    from swarmgames.game.meanfield import SOURCE_CHUNK_ELEMS
    from swarmgames.game.meanfield_compiled import PARALLEL_MIN_GAMES
    from swarmgames.game.stage import MAX_PAIR_ELEMS

    budget = MAX_PAIR_ELEMS if max_pair_elems is None else int(max_pair_elems)
    n, k, a = int(n_robots), max(1, min(int(n_vars), int(n_robots))), int(n_actions)
    per_game = float(k * k * a * a)
    held = per_game / a if pair_on_demand else per_game
    games = n if n * held <= budget else max(1, min(n, int(budget // held)))
    entries = games * per_game
    if pair_on_demand:
        # One chunk's tables, and the rows at a profile (the kernel's output and its sum).
        chunk = min(games, max(PARALLEL_MIN_GAMES, SOURCE_CHUNK_ELEMS // max(1, k * a) ** 2))
        table = chunk * per_game * itemsize
        gathers = 2.0 * games * held * itemsize
    else:
        table = entries * itemsize
        # The measurement's gathers (int64 indices, values, masks) run beside the table.
        gathers = entries / a * _GATHER_BYTES
        if held_sharing is not None and k >= n and k * a >= held_sharing:
            from swarmgames.game.stage import sharing_games

            equal = min(n, sharing_games(1, k * k, a, budget))
            rows = equal * held / a * _HELD_ROW_BYTES
            if equal > games and 2 * per_game * itemsize + rows > table + gathers:
                games, table, gathers = equal, 2 * per_game * itemsize, rows
    # The unary integral runs before the pairwise table exists; the pairwise blocks, the
    # measurement's gathers and the owners' rows of the regrets each run beside it.
    work = max(
        float(unary_bytes) - table,
        float(owner_unary_bytes),
        float(pair_work_bytes),
        gathers,
    )
    parts = {
        "pairwise tables of one batch": table,
        "working blocks (unary integral, pairwise blocks or measurement)": work,
        "states of one batch and the inboxes": 8.0 * (state_dim + 2) * (3 * games * k * a + n * k),
    }
    if global_regret and not centralised:
        parts["owner rows kept for the global regret"] = float(n) * k * a * a * itemsize
    if centralised:
        parts["the centralised game"] = 20.0 * (n * a) ** 2
    ordered = tuple(sorted(parts.items(), key=lambda p: -p[1]))
    return MemoryEstimate(ordered, k, games)
