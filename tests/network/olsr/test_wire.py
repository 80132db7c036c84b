"""OLSR packet sizes against RFC 3626's packet and message formats, worked out by hand."""

import numpy as np
import pytest

from swarmgames.network.olsr import wire
from swarmgames.network.olsr.wire import hello_size, tc_size


def test_header_sizes_are_the_rfc_ones():
    # RFC 3626 3.3: packet length (16) + packet sequence number (16).
    assert wire.PACKET_HEADER == 4
    # RFC 3626 3.3.2, IPv4: type (8), Vtime (8), size (16), originator (32), TTL (8),
    # hop count (8), message sequence number (16).
    assert wire.MESSAGE_HEADER == 12
    # RFC 3626 6.1: reserved (16), Htime (8), Willingness (8); per link message: link code (8),
    # reserved (8), link message size (16); 9.1: ANSN (16), reserved (16).
    assert wire.HELLO_HEADER == wire.LINK_MESSAGE_HEADER == wire.TC_HEADER == 4
    assert wire.ADDRESS == 4
    # IPv4 (20, no options) + UDP (8), RFC 3626 3.1: port 698.
    assert wire.UDP_IP_HEADER == 28
    assert wire.OLSR_PORT == 698


def test_hello_two_sym_one_asym_neighbour():
    # Two link messages (RFC 3626 6.1: SYM with 2 addresses, ASYM with 1): packet header (3.3),
    # message header (3.3.2), HELLO header (6.1), then each link message's header + addresses.
    assert hello_size(2, 3) == 4 + 12 + 4 + (4 + 8) + (4 + 4) == 40


def test_empty_hello_is_headers_only():
    # A node that has heard no one still sends a HELLO (RFC 3626 6.2): no link messages.
    assert hello_size(0, 0) == 4 + 12 + 4 == 20


def test_hello_with_every_link_code():
    # One neighbour each of ASYM (1), SYM (6), MPR (10), LOST (3): four link messages.
    assert hello_size(4, 4) == 4 + 12 + 4 + 4 * (4 + 4) == 52


def test_ns3_layout_is_one_link_message_per_neighbour():
    # ns-3 3.44 SendHello writes a link message per link tuple: 3 neighbours, 3 link messages.
    assert hello_size(3, 3) == 4 + 12 + 4 + 3 * (4 + 4) == 44


@pytest.mark.parametrize(("n", "size"), [(0, 20), (1, 24), (2, 28), (7, 48)])
def test_tc_size(n, size):
    # RFC 3626 3.3 + 3.3.2 + 9.1: ANSN + reserved, then 4 bytes per advertised neighbour.
    assert tc_size(n) == 4 + 12 + 4 + 4 * n == size


def test_sizes_are_vectorised_int64():
    groups, neigh = np.array([0, 1, 2]), np.array([0, 3, 5])
    out = hello_size(groups, neigh)
    assert out.dtype == np.int64
    assert out.tolist() == [hello_size(g, k) for g, k in zip(groups, neigh, strict=True)]
    assert tc_size(np.arange(3)).tolist() == [20, 24, 28]
