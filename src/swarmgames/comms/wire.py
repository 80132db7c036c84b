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

:func:`encode_messages` writes these bytes (the payload of the UDP datagrams that the ``ns3``
communication model sends through ns-3) and :func:`decode_messages` reads them back.

References
----------
.. [1] M. Fernando et al., "Graphical Games for UAV Swarm Control Under Time-Varying
   Communication Networks", ICRA 2022 workshop, section II.C (what robot i needs from j).
.. [2] IEEE 802.11-2016, sections 9.2 (MAC frame format) and 17.3.2 (OFDM PPDU: 16 µs
   preamble, 4 µs SIGNAL field); RFC 768 (UDP) and RFC 791 (IPv4) header sizes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from swarmgames.arrays import freeze_fields

__all__ = [
    "FRAME_OVERHEAD_BYTES",
    "HEADER_BYTES",
    "PREAMBLE_S",
    "StateMessages",
    "airtime_s",
    "decode_messages",
    "encode_messages",
    "message_bytes",
    "ofdm_airtime_s",
]

#: Fixed part of the payload: sender, timestamp, D and |N_j|.
HEADER_BYTES = 4 + 8 + 1 + 2
#: UDP (8) and IPv4 (20) headers, 802.11 MAC header (24), LLC/SNAP (8) and FCS (4).
FRAME_OVERHEAD_BYTES = 8 + 20 + 24 + 8 + 4
#: 802.11a OFDM preamble (16 µs) and SIGNAL field (4 µs).
PREAMBLE_S = 20e-6
#: The fixed fields, packed little-endian: sender, timestamp, D, |N_j|.
_HEADER = np.dtype([("sender", "<u4"), ("stamp", "<f8"), ("dim", "u1"), ("count", "<u2")])


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


def ofdm_airtime_s(
    payload_bytes, rate_mbps: float = 6.0, overhead_bytes: int = FRAME_OVERHEAD_BYTES
):
    """Airtime of one 802.11a OFDM frame as ns-3 transmits it, seconds.

    The preamble and SIGNAL field (20 µs), then the 16 SERVICE bits, the frame and the 6
    tail bits in whole OFDM symbols of 4 µs, each carrying ``4 rate_mbps`` data bits (IEEE
    802.11-2016 17.4.3; ns-3's ``OfdmPhy::GetPayloadDuration``).

    Parameters
    ----------
    payload_bytes : array_like of int
        UDP payload of each frame, bytes.
    rate_mbps : float
        PHY rate, one of 802.11a's (6 to 54 Mbit/s).
    overhead_bytes : int
        Headers around the payload (default: UDP/IPv4, MAC, LLC/SNAP and FCS).

    Examples
    --------
    >>> round(float(ofdm_airtime_s(91)) * 1e6, 1)  # ns-3: 232 µs for a 91-byte message
    232.0
    """
    bits = 16 + 8 * (np.asarray(payload_bytes, dtype=np.int64) + int(overhead_bytes)) + 6
    per_symbol = 4.0 * float(rate_mbps)
    return PREAMBLE_S + 4e-6 * np.ceil(bits / per_symbol)


@dataclass(frozen=True, eq=False)
class StateMessages:
    """M decoded state messages (read-only arrays).

    Parameters
    ----------
    sender : ndarray of int64, shape (M,)
    stamp : ndarray of float64, shape (M,)
        When each message was sent (the stage time), seconds.
    state, mean : ndarray of float64, shape (M, D)
        S_j and S̄_j.
    nbh : ndarray of int32, shape (M, L)
        N_j, -1 padded (L = the longest N_j, at least 1).
    """

    sender: np.ndarray
    stamp: np.ndarray
    state: np.ndarray
    mean: np.ndarray
    nbh: np.ndarray

    def __post_init__(self) -> None:
        freeze_fields(self)


def encode_messages(sender, stamp, state, mean, indptr, members) -> tuple[np.ndarray, np.ndarray]:
    """The wire bytes of M state messages, one after the other.

    Parameters
    ----------
    sender : array_like of int, shape (M,)
    stamp : float or array_like of float, shape (M,)
        Send time of each message, seconds.
    state, mean : array_like of float, shape (M, D)
        S_j and S̄_j of each sender.
    indptr, members : array_like of int
        N_j of message m is ``members[indptr[m]:indptr[m + 1]]`` (CSR).

    Returns
    -------
    buffer : ndarray of uint8, shape (B,)
        The messages back to back; message m is ``buffer[offsets[m]:offsets[m + 1]]``,
        :func:`message_bytes` long.
    offsets : ndarray of int64, shape (M + 1,)

    Examples
    --------
    >>> buf, off = encode_messages([4], 2.5, [[1.0, 2.0, 3.0]], [[0.0, 0.0, 0.0]], [0, 2], [4, 6])
    >>> off.tolist(), decode_messages(buf, off).nbh.tolist()
    ([0, 71], [[4, 6]])
    """
    state = np.ascontiguousarray(state, dtype="<f8")
    m, dim = state.shape
    indptr = np.asarray(indptr, dtype=np.int64)
    count = np.diff(indptr)
    offsets = np.concatenate([[0], np.cumsum(message_bytes(dim, count))]).astype(np.int64)
    head = np.empty(m, dtype=_HEADER)
    head["sender"], head["stamp"], head["dim"], head["count"] = sender, stamp, dim, count
    fixed = np.concatenate(
        [
            head.view(np.uint8).reshape(m, HEADER_BYTES),
            np.concatenate([state, np.asarray(mean, dtype="<f8")], axis=1).view(np.uint8),
        ],
        axis=1,
    )
    buffer = np.empty(int(offsets[-1]), dtype=np.uint8)
    buffer[offsets[:-1, None] + np.arange(fixed.shape[1])] = fixed
    row = np.repeat(np.arange(m), count)
    start = offsets[row] + fixed.shape[1] + 4 * (np.arange(row.size) - indptr[row])
    ids = np.asarray(members, dtype="<u4")[: row.size].view(np.uint8).reshape(-1, 4)
    buffer[start[:, None] + np.arange(4)] = ids
    return buffer, offsets


def decode_messages(buffer, offsets) -> StateMessages:
    """Read back the messages of :func:`encode_messages` (or of received datagrams).

    Parameters
    ----------
    buffer : array_like of uint8
    offsets : array_like of int, shape (M + 1,)
        Message m is ``buffer[offsets[m]:offsets[m + 1]]``.

    Returns
    -------
    StateMessages

    Raises
    ------
    ValueError
        If the messages have different state dimensions, or a message's length is not the
        :func:`message_bytes` of its own D and |N_j|.
    """
    buffer = np.asarray(buffer, dtype=np.uint8)
    offsets = np.asarray(offsets, dtype=np.int64)
    start = offsets[:-1]
    m = start.size
    if m == 0:
        empty = np.zeros((0, 0))
        return StateMessages(
            np.zeros(0, np.int64), np.zeros(0), empty, empty, np.full((0, 1), -1, np.int32)
        )
    head = buffer[start[:, None] + np.arange(HEADER_BYTES)].copy().view(_HEADER).ravel()
    dims = np.unique(head["dim"])
    if dims.size != 1:
        raise ValueError(f"messages must share one state dimension D (got {dims.tolist()})")
    dim = int(dims[0])
    count = head["count"].astype(np.int64)
    bad = np.flatnonzero(np.diff(offsets) != message_bytes(dim, count))
    if bad.size:
        k = int(bad[0])
        raise ValueError(
            f"message {k} must be 15 + 16 D + 4 |N_j| = {int(message_bytes(dim, count[k]))} "
            f"bytes long (got {int(offsets[k + 1] - offsets[k])})"
        )
    body = buffer[start[:, None] + HEADER_BYTES + np.arange(16 * dim)].copy()
    values = body.view("<f8").reshape(m, 2, dim)
    width = max(int(count.max()), 1)
    slot = np.arange(width)
    used = slot < count[:, None]
    at = start[:, None] + HEADER_BYTES + 16 * dim + 4 * slot
    raw = buffer[np.where(used, at, 0)[..., None] + np.arange(4)].copy().view("<u4")[..., 0]
    return StateMessages(
        sender=head["sender"].astype(np.int64),
        stamp=head["stamp"].astype(np.float64),
        state=values[:, 0].astype(np.float64),
        mean=values[:, 1].astype(np.float64),
        nbh=np.where(used, raw, -1).astype(np.int32),
    )
