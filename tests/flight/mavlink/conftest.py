"""A MAVLink vehicle on a free 127.0.0.1 port and a pymavlink client it sends to, driven in lockstep."""

import math
import os
import socket
import struct

import pytest

os.environ.setdefault("MAVLINK20", "1")

from pymavlink import mavutil

from flight.mavlink import MavlinkVehicle
from flight.signing import new_key, now_timestamp
from flight.sim import Simulator

ACCEPTED, TEMPORARILY_REJECTED, DENIED, UNSUPPORTED = 0, 1, 2, 3


def free_port():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Link:
    """The vehicle plus a pymavlink client listening where the vehicle sends (its "GCS" address).

    Like a ground station, the client sends a HEARTBEAT every simulated second (``gcs_heartbeat``), so the vehicle's
    data-link failsafe stays quiet unless a test stops it.
    """

    def __init__(self, vehicle, client):
        self.vehicle = vehicle
        self.client = client
        self.gcs_heartbeat = True
        self._next_beat = 0.0
        # A udpin client answers the addresses it has heard from: let the vehicle's first heartbeat arrive.
        self.first_heartbeat = self.wait("HEARTBEAT", 1.0)

    @property
    def mav(self):
        return self.client.mav

    def step(self):
        """One vehicle tick, after the client's heartbeat if one is due."""
        if self.gcs_heartbeat and self.vehicle.sim.time_s >= self._next_beat:
            self._next_beat = self.vehicle.sim.time_s + 1.0
            self.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS, mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        self.vehicle.step()

    def run_for(self, seconds):
        for _ in range(round(seconds / self.vehicle.tick_s)):
            self.step()

    def wait(self, msg_type, timeout_s=5.0, cond=lambda m: True):
        """Step the vehicle tick by tick until a ``msg_type`` message satisfying ``cond`` arrives."""
        ticks = math.ceil(timeout_s / self.vehicle.tick_s)
        for _ in range(ticks + 1):
            while (msg := self.client.recv_match(blocking=False)) is not None:
                if msg.get_type() == msg_type and cond(msg):
                    return msg
            self.step()
        return None

    def fresh(self, msg_type, timeout_s=2.0, cond=lambda m: True):
        """Like :meth:`wait`, ignoring anything already received."""
        self.drain()
        return self.wait(msg_type, timeout_s, cond)

    def collect(self, msg_type, seconds):
        """Every ``msg_type`` message over ``seconds`` of simulated time."""
        self.drain()
        out = []
        for _ in range(round(seconds / self.vehicle.tick_s)):
            self.step()
            while (msg := self.client.recv_match(blocking=False)) is not None:
                if msg.get_type() == msg_type:
                    out.append(msg)
        return out

    def drain(self):
        while self.client.recv_match(blocking=False) is not None:
            pass

    def command(self, command, *params, timeout_s=2.0):
        p = [*params, *([0.0] * (7 - len(params)))]
        self.drain()
        self.mav.command_long_send(1, 1, command, 0, *p)
        return self.wait("COMMAND_ACK", timeout_s, lambda m: m.command == command)

    def command_int(self, command, frame, params, x, y, z, timeout_s=2.0):
        self.drain()
        self.mav.command_int_send(1, 1, frame, command, 0, 0, *params, x, y, z)
        return self.wait("COMMAND_ACK", timeout_s, lambda m: m.command == command)

    def fly_until(self, cond, timeout_s):
        """Step until ``cond(vehicle.sim.state())``; True if it happened."""
        for _ in range(math.ceil(timeout_s / self.vehicle.tick_s)):
            self.step()
            self.drain()
            if cond(self.vehicle.sim.state()):
                return True
        return False


def open_link(key=None):
    """A :class:`Link`; with ``key``, vehicle and client sign with it (pymavlink's ``setup_signing``)."""
    port = free_port()
    client = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255, source_component=190)
    if key is not None:
        client.setup_signing(key, sign_outgoing=True, initial_timestamp=now_timestamp(), link_id=1)
    vehicle = MavlinkVehicle(Simulator(seed=3), gcs=("127.0.0.1", port), api=None, signing_key=key)
    return Link(vehicle, client)


@pytest.fixture
def link():
    link = open_link()
    try:
        yield link
    finally:
        link.vehicle.close()
        link.client.close()


@pytest.fixture
def signed_link():
    """A link signed with a fresh key: what changes safety parameters or forces a disarm in the air."""
    link = open_link(new_key())
    try:
        yield link
    finally:
        link.vehicle.close()
        link.client.close()


def take_off(link, alt_m):
    """Arm and climb to ``alt_m`` above home (COMMAND_LONG altitude is above mean sea level); ends in Hold."""
    m = mavutil.mavlink
    home_alt = link.vehicle.sim.environment.home.alt_msl_m
    assert link.command(m.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == ACCEPTED
    nan = math.nan
    assert link.command(m.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, nan, nan, nan, home_alt + alt_m).result == ACCEPTED
    assert link.fly_until(lambda s: link.vehicle.mode.name == "HOLD", 30.0)


def set_param(link, name, value):
    """PARAM_SET over the link; returns the PARAM_VALUE answer (INT32 values are sent bytewise)."""
    m = mavutil.mavlink
    spec = link.vehicle.params.specs[name]
    field = float(value)
    if spec.param_type == m.MAV_PARAM_TYPE_INT32:
        field = struct.unpack("<f", struct.pack("<i", int(value)))[0]
    link.drain()
    link.mav.param_set_send(1, 1, name.encode(), field, spec.param_type)
    return link.wait("PARAM_VALUE", 1.0, lambda p: p.param_id == name)


def mode_of(link):
    """The vehicle's mode (through a function, so that type checkers do not narrow it across steps)."""
    return link.vehicle.mode
