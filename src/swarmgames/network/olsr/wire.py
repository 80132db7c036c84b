"""Sizes in bytes of the OLSR control packets the engine sends (RFC 3626 formats, IPv4).

Every OLSR packet starts with a 4-byte packet header (RFC 3626 section 3.3: packet length,
packet sequence number) followed by its messages, each with a 12-byte message header
(section 3.3.2: message type, Vtime, message size, originator address, TTL, hop count, message
sequence number). The two messages the model sends:

========================  ======================================================  =========
part                      fields                                                   bytes
========================  ======================================================  =========
packet header (3.3)       packet length, packet sequence number                    4
message header (3.3.2)    type, Vtime, size, originator, TTL, hop count, seq no.   12
HELLO (6.1)               reserved, Htime, Willingness                             4
  per link code (6.1)     link code, reserved, link message size                   4
  per neighbour (6.1)     neighbour interface address                              4
TC (9.1)                  ANSN, reserved                                           4
  per neighbour (9.1)     advertised neighbour main address                        4
UDP/IPv4 (port 698)       20-byte IPv4 header + 8-byte UDP header, per packet      28
========================  ======================================================  =========

Packing. The engine sends every message in a packet of its own (its own jitter, its own
time on the air), so :func:`hello_size` and :func:`tc_size` are the size of a whole OLSR packet:
packet header + message header + body. ns-3 3.44 packs more tightly:
``RoutingProtocol::QueueMessage`` appends a message to the node's queue and, if no send is
pending, schedules one after the message's jitter; ``SendQueuedMessages`` then puts everything
queued in one packet (up to 64 messages). A HELLO and a TC built together (every 10 s with the
default intervals) or a TC forwarded while a send is pending therefore share one packet header
and one UDP/IP header in ns-3. The model's packet headers and UDP/IP overhead are thus an upper
bound on ns-3's (4 + 28 bytes for each message that ns-3 would have queued behind another); the
message bytes are exact.

Link messages. RFC 3626 section 6.1 lets a HELLO group all neighbours with the same link code
into one link message, and the engine counts HELLOs that way: one 4-byte link-message header per
distinct link code, 4 bytes per neighbour. ns-3 3.44's ``SendHello`` does not group: it writes one
link message per link tuple, so its HELLO with ``k`` neighbours is ``hello_size(k, k)`` bytes,
4 bytes more per neighbour beyond the first of each code.

The UDP/IP headers are not in these sizes; they are on-air overhead, 28 bytes per packet
(:data:`UDP_IP_HEADER`), and the MAC/PHY framing below that is left out entirely.

References
----------
.. [1] RFC 3626 sections 3.3 (packet format), 3.3.2 (message header), 6.1 (HELLO format),
   9.1 (TC format), 3.1 (UDP port 698).
.. [2] ns-3 3.44 ``src/olsr/model/olsr-header.cc`` (``GetSerializedSize``) and
   ``olsr-routing-protocol.cc`` (``QueueMessage``, ``SendQueuedMessages``, ``SendHello``).

Examples
--------
A HELLO listing two symmetric neighbours and one asymmetric one (two link codes):

>>> int(hello_size(2, 3))
40
>>> int(tc_size(2))
28
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "ADDRESS",
    "HELLO_HEADER",
    "LINK_MESSAGE_HEADER",
    "MESSAGE_HEADER",
    "OLSR_PORT",
    "PACKET_HEADER",
    "TC_HEADER",
    "UDP_IP_HEADER",
    "hello_size",
    "tc_size",
]

#: RFC 3626 section 3.3: packet length (16 bits), packet sequence number (16 bits).
PACKET_HEADER = 4
#: RFC 3626 section 3.3.2, IPv4: type, Vtime, message size, originator, TTL, hop count, seq no.
MESSAGE_HEADER = 12
#: RFC 3626 section 6.1: reserved (16 bits), Htime, Willingness.
HELLO_HEADER = 4
#: RFC 3626 section 6.1: link code, reserved, link message size.
LINK_MESSAGE_HEADER = 4
#: RFC 3626 section 9.1: ANSN (16 bits), reserved (16 bits).
TC_HEADER = 4
#: One IPv4 address.
ADDRESS = 4
#: IPv4 header (20, no options) + UDP header (8) around every OLSR packet.
UDP_IP_HEADER = 28
#: RFC 3626 section 3.1: OLSR's UDP port.
OLSR_PORT = 698


def hello_size(n_link_codes, n_neighbours):
    """Bytes of an OLSR packet carrying one HELLO (RFC 3626 sections 3.3, 3.3.2, 6.1).

    Parameters
    ----------
    n_link_codes : int or ndarray of int
        Number of link messages: distinct link codes among the listed neighbours.
    n_neighbours : int or ndarray of int
        Number of neighbour interface addresses listed (same shape as ``n_link_codes``).

    Returns
    -------
    int or ndarray of int64
        ``4 + 12 + 4 + 4 * n_link_codes + 4 * n_neighbours``; UDP/IP headers not included.
    """
    return (
        PACKET_HEADER
        + MESSAGE_HEADER
        + HELLO_HEADER
        + LINK_MESSAGE_HEADER * np.asarray(n_link_codes, dtype=np.int64)
        + ADDRESS * np.asarray(n_neighbours, dtype=np.int64)
    )


def tc_size(n_advertised):
    """Bytes of an OLSR packet carrying one TC (RFC 3626 sections 3.3, 3.3.2, 9.1).

    A forwarded TC has the size of the original: forwarding changes only TTL and hop count.

    Parameters
    ----------
    n_advertised : int or ndarray of int
        Number of advertised neighbour main addresses (the originator's MPR selectors).

    Returns
    -------
    int or ndarray of int64
        ``4 + 12 + 4 + 4 * n_advertised``; UDP/IP headers not included.
    """
    return (
        PACKET_HEADER
        + MESSAGE_HEADER
        + TC_HEADER
        + ADDRESS * np.asarray(n_advertised, dtype=np.int64)
    )
