"""The link term at risk: what a joint move takes from the radio links near their loss.

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

__all__ = ["LINK_CHUNK_ELEMS", "LinkRisk"]

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
        # The mean power alone decides, without shadowing or fading.
        object.__setattr__(
            self, "radio", replace(self.radio, shadowing_sigma_db=0.0, nakagami_m=None)
        )

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
