"""Attackers for the attack suite: a socket of their own on 127.0.0.1, speaking MAVLink with pymavlink.

The vehicle under attack is the lockstep harness of ``tests/flight/mavlink`` (a pymavlink ground station at the
vehicle's GCS address, signed or not), so every attack is deterministic and takes simulated, not wall, time.
"""

import os
import socket
from typing import Any

import pytest

os.environ.setdefault("MAVLINK20", "1")

from pymavlink.dialects.v20 import common as mavlink2

from flight.signing import new_key, now_timestamp
from tests.flight.mavlink.conftest import open_link


class Attacker:
    """A stranger on another socket: sends MAVLink (signed with ``key`` when given) and collects what it hears."""

    def __init__(self, target, *, system_id=255, key=None, link_id=7):
        self.target = target
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.setblocking(False)
        self.mav = mavlink2.MAVLink(None, srcSystem=system_id, srcComponent=190)
        if key is not None:
            self.mav.signing.secret_key = key
            self.mav.signing.sign_outgoing = True
            self.mav.signing.link_id = link_id
            self.mav.signing.timestamp = now_timestamp()
        self.parser = mavlink2.MAVLink(None)
        self.parser.robust_parsing = True
        self.heard = []

    @property
    def address(self):
        return self.sock.getsockname()

    def pack(self, msg):
        buf = msg.pack(self.mav)
        self.mav.seq = (self.mav.seq + 1) % 256
        return buf

    def send(self, msg):
        self.raw(self.pack(msg))

    def raw(self, buf, to=None):
        self.sock.sendto(bytes(buf), to or self.target)

    def command(self, command, *params):
        p = [*params, *([0.0] * (7 - len(params)))]
        self.send(self.mav.command_long_encode(1, 1, command, 0, *p))

    def listen(self):
        """Read what has arrived; returns the messages (also kept in ``heard``)."""
        out: list[Any] = []
        while True:
            try:
                data = self.sock.recv(65535)
            except (BlockingIOError, InterruptedError):
                break
            out.extend(m for m in self.parser.parse_buffer(data) or [] if m.get_type() != "BAD_DATA")
        self.heard.extend(out)
        return out

    def close(self):
        self.sock.close()


@pytest.fixture
def attackers():
    """Make attackers with ``attackers(target, ...)``; all are closed after the test."""
    made = []

    def make(target, **kwargs):
        attacker = Attacker(target, **kwargs)
        made.append(attacker)
        return attacker

    yield make
    for attacker in made:
        attacker.close()


def _closing(link):
    try:
        yield link
    finally:
        link.vehicle.close()
        link.client.close()


@pytest.fixture
def signed():
    """The vehicle with a fresh key and its ground station signing with it."""
    key = new_key()
    link = open_link(key)
    link.key = key
    yield from _closing(link)


@pytest.fixture
def open_vehicle():
    """The vehicle without signing and its (unsigned) ground station."""
    yield from _closing(open_link())
