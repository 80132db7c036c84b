"""Random local games for the game-engine tests."""

from __future__ import annotations

import numpy as np
import scipy.sparse.csgraph as csgraph

from swarmgames.game import DisplacementActions, FunctionPotentials, LocalGameBatch, TablePotentials
from swarmgames.network import TopologySnapshot


def random_games(
    seed: int,
    n_games: int,
    n_vars: int,
    n_actions: int,
    *,
    ragged: bool = True,
    pairwise: bool = True,
    scale: float = 1.0,
) -> tuple[LocalGameBatch, TablePotentials]:
    """B random local games: left-packed valid variables (variable 0 always valid), random
    valid-action masks with at least one valid action, standard-normal tables. Padding and
    invalid entries of the tables hold NaN, which the engine must never read."""
    rng = np.random.default_rng(seed)
    b, k, a = n_games, n_vars, n_actions
    n_valid = rng.integers(1, k + 1, size=b) if ragged else np.full(b, k)
    mask = np.arange(k)[None, :] < n_valid[:, None]
    amask = rng.random((b, k, a)) < 0.8 if ragged else np.ones((b, k, a), dtype=bool)
    amask[np.arange(b)[:, None], np.arange(k)[None, :], rng.integers(0, a, size=(b, k))] = True
    amask &= mask[:, :, None]
    states = rng.normal(size=(b, k, 2))
    batch = LocalGameBatch(
        owner=np.arange(b),
        members=np.where(mask, np.arange(k)[None, :] + 100, -1),
        mask=mask,
        states=states,
        is_virtual=np.zeros((b, k), dtype=bool),
        next_states=np.broadcast_to(states[:, :, None, :], (b, k, a, 2)),
        action_mask=amask,
    )
    u = scale * rng.normal(size=(b, k, a))
    u[~amask] = np.nan
    p = None
    if pairwise:
        p = scale * rng.normal(size=(b, k, k, a, a))
        p[~mask] = np.nan
    return batch, TablePotentials(u, p)


def trimmed_game(batch: LocalGameBatch, pot: TablePotentials, g: int):
    """Game ``g`` alone, without padding columns, and its potentials."""
    one = batch.select([g]).trim()
    k, a = one.n_vars, one.n_actions
    u = np.asarray(pot.unary_table)[g : g + 1, :k, :a]
    p = None
    if pot.pairwise_table is not None:
        p = np.asarray(pot.pairwise_table)[g : g + 1, :k, :k, :a, :a]
    return one, TablePotentials(u, p)


def disk_snapshot(positions: np.ndarray, radius: float, time: float = 0.0) -> TopologySnapshot:
    """Snapshot with BFS hop counts on the disk graph of ``radius`` (docs/reference.md section 4:
    settled OLSR hop counts equal BFS hop counts on the disk graph)."""
    pos = np.asarray(positions, dtype=float)
    d = np.linalg.norm(pos[:, None, :] - pos[None, :, :], axis=-1)
    adj = (d <= radius) & ~np.eye(len(pos), dtype=bool)
    hops = csgraph.shortest_path(adj.astype(float), unweighted=True)
    return TopologySnapshot.from_hop_matrix(time, hops)


#: A small 2-D stage shared by the solver and stage tests: move towards (100, 100), stay apart.
MODEL = DisplacementActions.headings(5.0, 8, lower=[0.0, 0.0], upper=[200.0, 200.0])
POT = FunctionPotentials(
    lambda s: -np.linalg.norm(s - 100.0, axis=-1) / 50.0,
    lambda s, t: -np.exp(-np.linalg.norm(s - t, axis=-1) / 20.0),
)


def swarm(n: int = 12, seed: int = 0):
    """``n`` robots uniform in a 200 m square and their 70 m disk-graph snapshot."""
    pos = np.random.default_rng(seed).uniform(0, 200, size=(n, 2))
    return pos, disk_snapshot(pos, 70.0)


def curie_weiss(
    k: int = 600, coupling: float = 0.97, offset: float = 5.0, seed: int = 0, levels: int = 2
):
    """A Curie-Weiss (mean-field Ising) game of ``k`` spins (D. Koller and N. Friedman,
    Probabilistic Graphical Models, 2009, section 11.5), each of ``levels`` values evenly
    spaced in [-1, 1] (critical coupling 1 for two levels, about 1.8 for four), as float32
    logits (1, k, levels) at β = 1 and its pair table (1, k, levels, k, levels): a large
    constant term (``offset``) cancels in every softmax but not in a float32 sum."""
    spin = np.linspace(-1.0, 1.0, levels)
    rng = np.random.default_rng(seed)
    unary = (0.001 + 0.01 * rng.normal(size=(1, k, 1))) * spin + offset * k
    pair = np.full((1, k, levels, k, levels), offset) + (coupling / k) * spin[:, None, None] * spin
    pair[0, np.arange(k), :, np.arange(k), :] = 0.0
    return unary.astype(np.float32), pair.astype(np.float32)


def games_of(mask, states, next_states, action_mask) -> LocalGameBatch:
    """The games of the arrays of a batch (``mask`` (B, K), ``states`` (B, K, D),
    ``next_states`` (B, K, A, D), ``action_mask`` (B, K, A)), variable k of every game
    being robot k (game b owned by robot 0)."""
    mask = np.asarray(mask, dtype=bool)
    b, k = mask.shape
    return LocalGameBatch(
        owner=np.zeros(b, dtype=np.int32),
        members=np.where(mask, np.arange(k), -1),
        mask=mask,
        states=states,
        is_virtual=np.zeros((b, k), dtype=bool),
        next_states=next_states,
        action_mask=action_mask,
    )
