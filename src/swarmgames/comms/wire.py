"""The wire format of a robot's state message, and what it costs on the air.

Every control period each robot broadcasts one state message (the only communication the
local games need, paper section II.C): its id, the time it was sent, its state S_j, the
members of its neighbourhood N_j (from its own routing table) and the mean state S̄_j of eq. 3
as the robot itself knows them. Little-endian, no padding:

=============  ==============  ==================
field          type            bytes
=============  ==============  ==================
sender         uint32          4
timestamp      float64, s      8
D              uint8           1
|N_j|          uint16          2
S_j            D x float64     8 D
S̄_j            D x float64     8 D
N_j            |N_j| x uint32  4 |N_j|
=============  ==============  ==================

so a message carries ``15 + 16 D + 4 |N_j|`` bytes of payload: 91 bytes for a UAV at
(x, y, z) with 7 robots in its 2-hop neighbourhood. On the air it rides in UDP/IPv4 (28 bytes
of headers) in an 802.11 data frame (24-byte MAC header, 8-byte LLC/SNAP, 4-byte FCS) sent at
the PHY rate after the 20 µs 802.11a preamble and signal field.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, section II.C (what robot i needs from j).
.. [2] IEEE 802.11-2016, sections 9.2 (MAC frame format) and 17.3.2 (OFDM PPDU: 16 µs
   preamble, 4 µs SIGNAL field); RFC 768 (UDP) and RFC 791 (IPv4) header sizes.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "FRAME_OVERHEAD_BYTES",
    "HEADER_BYTES",
    "PREAMBLE_S",
    "airtime_s",
    "message_bytes",
]

#: Fixed part of the payload: sender, timestamp, D and |N_j|.
HEADER_BYTES = 4 + 8 + 1 + 2
#: UDP (8) and IPv4 (20) headers, 802.11 MAC header (24), LLC/SNAP (8) and FCS (4).
FRAME_OVERHEAD_BYTES = 8 + 20 + 24 + 8 + 4
#: 802.11a OFDM preamble (16 µs) and SIGNAL field (4 µs).
PREAMBLE_S = 20e-6


def message_bytes(state_dim: int, members) -> np.ndarray:
    """Payload of each state message, bytes: ``15 + 16 D + 4 |N_j|``.

    Parameters
    ----------
    state_dim : int
        D, the number of state columns.
    members : array_like of int
        |N_j| of each sender (its own id included).

    Examples
    --------
    >>> message_bytes(3, [7]).tolist()
    [91]
    """
    return HEADER_BYTES + 16 * int(state_dim) + 4 * np.asarray(members, dtype=np.int64)


def airtime_s(payload_bytes, rate_mbps: float) -> np.ndarray:
    """Time one frame of ``payload_bytes`` occupies the channel at ``rate_mbps``, seconds.

    Examples
    --------
    >>> round(float(airtime_s(91, 6.0)) * 1e6, 1)  # microseconds
    226.7
    """
    bits = 8.0 * (np.asarray(payload_bytes, dtype=float) + FRAME_OVERHEAD_BYTES)
    return PREAMBLE_S + bits / (float(rate_mbps) * 1e6)
