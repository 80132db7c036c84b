"""Link terms that guard the radio links: what a joint move takes from the links near their
loss (the term at risk), and the discs that keep the relative neighbour links (link keeping).

Eq. 6 rewards every pair of a neighbourhood for the link quality between its next positions,
:math:`\\psi_R(\\lVert S_k(x_k) - S_l(x_l) \\rVert)`: a pull towards every neighbour, summed over
the neighbourhood, so it grows with its size and holds the swarm together even where every
link is strong. The term at risk charges only what a joint move takes from the links near
their loss:

.. math::

    \\phi_p^{risk}(k, x_k, l, x_l) = -\\frac{c_{link}\\, m_{ROI}}{2 \\alpha_b}\\,
        [P(d_{kl}) \\ge P_{th}]\\;
        \\max\\bigl(0,\\; s(\\lVert S_k(x_k) - S_l(x_l) \\rVert) - s(d_{kl})\\bigr),
        \\qquad s(d) = \\max\\bigl(0,\\; P_{th} + m - P(d)\\bigr)

where :math:`d_{kl}` is the pair's distance now, :math:`P(d)` the mean received power of the
network's radio model (Friis or log-distance, ns-3's formulas), :math:`P_{th}` its reception
threshold, :math:`m` the margin, :math:`s` the shortfall below the threshold plus the margin
and :math:`m_{ROI}` the ROI's mass (so that :math:`c_{link}`, ``coverage.link_cost_db``, is a
cost in the unary's dB units per dB of shortfall, like the move cost). A pair that is not
linked now costs nothing, and neither does a move that keeps a link's margin, nor one that
leaves a link short but no shorter than it is: the term keeps links from weakening, it does
not pull robots together (charging the shortfall itself would pull every linked pair inside
the margin's distance, and each new link with it, until the swarm contracts) and does not
grow with the neighbourhood.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop (arXiv 2205.02203), eqs. 1 and 6.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from swarmgames.missions.geometry import pair_distances
from swarmgames.network.parameters import RadioParameters
from swarmgames.network.propagation import PropagationModel, max_range

__all__ = ["LINK_CHUNK_ELEMS", "LinkKeeping", "LinkRisk"]


def _mean_power(radio: RadioParameters) -> RadioParameters:
    """``radio`` without shadowing or fading: the mean received power alone decides."""
    return replace(radio, shadowing_sigma_db=0.0, nakagami_m=None)


#: Most shortfall entries (pairs × A²) computed at once.
LINK_CHUNK_ELEMS = 2_000_000


@dataclass(frozen=True)
class LinkRisk:
    """The received-power shortfall of the links that exist now, for every joint move.

    Parameters
    ----------
    radio : RadioParameters
        The network's radio (``network.radio``): its mean received power and reception
        threshold decide which pairs are linked now and how much power a move leaves.
    margin_db : float
        m, the power above the threshold a link should keep, dB (>= 0).
    """

    radio: RadioParameters
    margin_db: float

    def __post_init__(self) -> None:
        if not (np.isfinite(self.margin_db) and self.margin_db >= 0):
            raise ValueError(f"link margin must be >= 0 dB and finite (got {self.margin_db})")
        object.__setattr__(self, "radio", _mean_power(self.radio))

    @property
    def range_m(self) -> float:
        """Distance up to which a pair is linked (mean power at the threshold), metres."""
        return max_range(self.radio)

    @property
    def safe_m(self) -> float:
        """Distance up to which a link keeps its margin (mean power at threshold + m),
        metres."""
        return max_range(replace(self.radio, rx_threshold_dbm=self.radio.rx_threshold_dbm
                                 + self.margin_db))  # fmt: skip

    def shortfall_db(self, distance: np.ndarray) -> np.ndarray:
        """:math:`\\max(0, P_{th} + m - P(d))` at ``distance`` metres, dB."""
        floor = self.radio.rx_threshold_dbm + self.margin_db
        return np.maximum(0.0, floor - PropagationModel(self.radio).mean_rx_power(distance))

    def blocks(self, batch, *, first_only: bool = False, max_elems: int = LINK_CHUNK_ELEMS):
        """How much every joint move adds to the shortfall of every pair of distinct valid
        variables of a game, neither a virtual mean, that is linked now and that some joint
        move can bring below its margin, in chunks of pairs.

        Only pairs linked now (distance at most :attr:`range_m`) and farther than
        :attr:`safe_m` less twice the longest move of the batch can fall short, so only
        their ``(A, A)`` blocks are computed; each pair's values do not depend on the
        chunking.

        Parameters
        ----------
        batch : LocalGameBatch
            Uses ``mask``, ``is_virtual``, ``states``, ``next_states`` and ``action_mask``;
            positions are the first three state columns.
        first_only : bool, default False
            Only the pairs whose first variable is variable 0 (the owner's rows).
        max_elems : int, default LINK_CHUNK_ELEMS
            Most entries ``P A²`` per chunk (at least one pair per chunk).

        Yields
        ------
        games, first, second : ndarray of int, shape (P,)
            Each pair as (game, variable k, variable l); both orders of a pair are listed.
        loss : ndarray, shape (P, A, A)
            ``loss[p, a, c]``: how much the shortfall grows when k takes a and l takes c,
            :math:`\\max(0, s(d') - s(d))`, dB (>= 0); values at invalid actions are
            meaningless.
        """
        range_m, safe_m = self.range_m, self.safe_m

        def near(gap, s_max):
            return (gap <= range_m) & (gap > safe_m - 2.0 * s_max - 1e-9)

        blocks = pair_distances(batch, near, max_elems, first_only=first_only, real=True)
        for cb, ck, cl, gap, d in blocks:
            now = self.shortfall_db(gap)[:, None, None]
            worse = self.shortfall_db(d)
            np.subtract(worse, now, out=worse)
            yield cb, ck, cl, np.maximum(worse, 0.0, out=worse)


@dataclass(frozen=True)
class LinkKeeping:
    """How far each move takes a robot outside the discs that keep its relative neighbour
    links, whatever the neighbours do.

    For every pair (k, l) of a game's robots that is linked now (distance :math:`d_{kl}` at
    most the radio's range R) and is a relative neighbour link of the robots the game knows
    (:func:`~swarmgames.missions.geometry.relative_neighbours`: no third robot is closer to
    both), k keeps within the disc of radius :math:`\\max(D, d_{kl}) / 2` around the pair's
    midpoint:

    .. math::

        v(k, x_k) = \\sum_l \\max\\Bigl(0,\\; \\bigl\\lVert S_k(x_k) - \\tfrac{S_k + S_l}{2}
            \\bigr\\rVert - \\tfrac{\\max(D, d_{kl})}{2}\\Bigr),
        \\qquad D = R - 2 s

    with :math:`s` the longest move in the game. If k and l both keep to their discs, their
    distance after the move is at most :math:`\\max(D, d_{kl})` [1]_, so the link holds
    whatever the other robot chooses, with room for one stage of a neighbour's stale
    position on each side (:math:`2 s`). Staying put is always inside the disc. The
    relative neighbourhood graph holds a minimum spanning tree of every component of the
    links, so keeping its links keeps every component whole while all other links may go;
    robots k and l find the same witnesses (a witness is a neighbour of both), so they agree
    on which links to keep when they know the same positions.

    Parameters
    ----------
    radio : RadioParameters
        The network's radio (``network.radio``): its mean received power and reception
        threshold give the range R.

    References
    ----------
    .. [1] H. Ando, Y. Oasa, I. Suzuki and M. Yamashita, "Distributed memoryless point
       convergence algorithm for mobile robots with limited visibility", IEEE Transactions
       on Robotics and Automation 15(5), 1999 (the midpoint disc of radius V / 2).
    """

    radio: RadioParameters

    def __post_init__(self) -> None:
        object.__setattr__(self, "radio", _mean_power(self.radio))

    @property
    def range_m(self) -> float:
        """R: the distance up to which a pair is linked (mean power at the threshold), metres."""
        return max_range(self.radio)

    def outside_m(
        self, batch, *, owner_only: bool = False, max_elems: int = LINK_CHUNK_ELEMS
    ) -> np.ndarray:
        """:math:`v(k, x_k)` for every game, variable and action, (B, K, A) metres (or the
        owners' rows, (B, A), with ``owner_only``); 0 for virtual means, padded variables and
        invalid actions. The witnesses are searched for in chunks of pairs of at most
        ``max_elems`` distances; the values do not depend on the chunking.

        Only pairs farther apart than :math:`D - 2 s` can leave a disc (a move reaches at
        most :math:`d_{kl} / 2 + s` from the midpoint), so only theirs are computed.
        """
        mask = np.asarray(batch.mask, dtype=bool)
        real = mask & ~np.asarray(batch.is_virtual, dtype=bool)
        amask = np.asarray(batch.action_mask, dtype=bool) & mask[..., None]
        pos = np.asarray(batch.states, dtype=float)[..., :3]
        nxt = np.asarray(batch.next_states, dtype=float)[..., :3]
        B, K, A = amask.shape
        out = np.zeros((B, 1 if owner_only else K, A))
        if B == 0 or K < 2:
            return out[:, 0] if owner_only else out
        # Each game's longest move (its own: the values do not depend on the batch).
        disp = np.linalg.norm(nxt - pos[:, :, None, :], axis=-1)
        s_max = np.where(amask, disp, 0.0).max(axis=(1, 2))  # (B,)
        keep = self.range_m - 2.0 * s_max
        pairs = real[:, :, None] & real[:, None, :] & ~np.eye(K, dtype=bool)
        if owner_only:
            pairs[:, 1:] = False
        gb, gk, gl = np.nonzero(pairs)
        gap = np.linalg.norm(pos[gb, gk] - pos[gb, gl], axis=-1)
        near = (gap <= self.range_m) & (gap > keep[gb] - 2.0 * s_max[gb] - 1e-9)
        gb, gk, gl, gap = gb[near], gk[near], gl[near], gap[near]
        # Relative neighbours within the game: no third known robot closer to both, in chunks
        # of pairs of at most max_elems distances to the game's others.
        alone = np.zeros(gb.size, dtype=bool)
        step = max(1, int(max_elems) // K)
        for lo in range(0, gb.size, step):
            cb, ck, cl = gb[lo : lo + step], gk[lo : lo + step], gl[lo : lo + step]
            d_k = np.linalg.norm(pos[cb] - pos[cb, ck][:, None], axis=2)  # (P, K)
            d_l = np.linalg.norm(pos[cb] - pos[cb, cl][:, None], axis=2)
            witness = real[cb] & (np.maximum(d_k, d_l) < gap[lo : lo + step, None])
            alone[lo : lo + step] = ~np.any(witness, axis=1)
        gb, gk, gl, gap = gb[alone], gk[alone], gl[alone], gap[alone]
        mid = 0.5 * (pos[gb, gk] + pos[gb, gl])  # (P, 3)
        radius = 0.5 * np.maximum(keep[gb], gap)
        over = np.maximum(
            0.0, np.linalg.norm(nxt[gb, gk] - mid[:, None], axis=-1) - radius[:, None]
        )
        rows = np.zeros_like(gk) if owner_only else gk
        np.add.at(out, (gb, rows), over)
        out[~(amask[:, :1] if owner_only else amask)] = 0.0
        return out[:, 0] if owner_only else out
