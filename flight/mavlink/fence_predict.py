"""Offboard velocity setpoints limited so the vehicle stops at the fence *before* a breach.

Why: a client streaming a velocity setpoint (MAVSDK sends one every 0.05 s, our agent every 0.2 s) flies on until
something stops it; detecting the breach afterwards (:mod:`flight.mavlink.failsafe`) leaves the vehicle its whole
stopping distance outside. PX4's ``GF_PREDICT`` (``geofence_params.c``; the PX4 user guide, "GeoFence") predicts
the motion and triggers the breach action before the fence; ours, with ``GF_PREDICT`` 1, shapes the setpoint
instead, so the vehicle stops :data:`STOP_MARGIN_M` inside and holds there while the setpoint keeps pointing out.

The rule, per tick while a velocity setpoint is flown (:meth:`~flight.mavlink.navigator.Navigator.update`):

* Horizontally, along the setpoint's direction: ``room`` is the distance to the first point outside the fence
  (``GF_MAX_HOR_DIST``'s cylinder and the uploaded areas, :class:`~flight.mavlink.geofence.Geofence`), searched in
  :data:`STEP_M` steps then refined by bisection; the speed along that direction is limited to
  ``min(sqrt(2·a·d), k·d)`` with ``d = room − margin`` (negative ``d`` backs off slowly), the shape the position
  controller uses to approach a target (:mod:`flight.sim.controller`). Motion along the fence is left alone.
* Vertically: a climb is limited the same way below ``GF_MAX_VER_DIST`` and a descent above ``GF_MIN_ALT`` (the
  floor, :mod:`flight.mavlink.params`).

The constants are ours, chosen below what the F450 model can do (it decelerates at up to g·tan 30° ≈ 5.7 m/s²).
"""

from __future__ import annotations

import math
from typing import NamedTuple

from flight.mavlink.geofence import Geofence

STOP_MARGIN_M = 1.0
"""The vehicle stops this far inside the fence (and above the floor)."""
ACCEL_XY_MPS2 = 2.0
"""Horizontal deceleration assumed (the controller's ``Limits.max_accel_xy_mps2``)."""
ACCEL_Z_MPS2 = 1.0
"""Vertical deceleration assumed."""
GAIN_PER_S = 0.8
"""Speed per metre of room near the boundary ((m/s)/m, the controller's horizontal position gain)."""
STEP_M = 1.0
BISECTIONS = 6
MAX_BACKOFF_MPS = 1.0


class Limited(NamedTuple):
    """The velocity to fly (NED, m/s) and whether it differs from the one asked for."""

    vn: float
    ve: float
    vd: float
    limited: bool


def _approach(speed: float, room_m: float) -> float:
    """The fastest speed towards a boundary ``room_m`` away that still stops :data:`STOP_MARGIN_M` short of it."""
    d = room_m - STOP_MARGIN_M
    if d <= 0:
        return max(GAIN_PER_S * d, -MAX_BACKOFF_MPS)
    return min(speed, math.sqrt(2.0 * ACCEL_XY_MPS2 * d), GAIN_PER_S * d)


def horizontal_room(fence: Geofence, north: float, east: float, un: float, ue: float, limit_m: float) -> float:
    """Metres from (north, east) along the unit direction (un, ue) to the first point outside the fence's
    horizontal limits, or ``limit_m`` when there is none that near; also ``limit_m`` from a point already outside
    (the breach is the failsafe's, and a setpoint back inside must not be turned round)."""
    if fence.violation(north, east, 0.0) is not None:
        return limit_m
    inside, d = 0.0, STEP_M
    while inside < limit_m:
        d = min(d, limit_m)
        if fence.violation(north + un * d, east + ue * d, 0.0) is not None:
            outside = d
            for _ in range(BISECTIONS):
                mid = 0.5 * (inside + outside)
                if fence.violation(north + un * mid, east + ue * mid, 0.0) is None:
                    inside = mid
                else:
                    outside = mid
            return inside
        inside, d = d, d + STEP_M
    return limit_m


def limit_velocity(
    fence: Geofence, north: float, east: float, alt_m: float, vn: float, ve: float, vd: float
) -> Limited:
    """``(vn, ve, vd)`` limited so that flying it from (north, east, ``alt_m`` above home) stops inside the fence
    and above the floor (see the module docstring)."""
    params = fence.params.values
    out_n, out_e, out_d = vn, ve, vd
    speed = math.hypot(vn, ve)
    if speed > 1e-6:
        un, ue = vn / speed, ve / speed
        lookahead = speed * speed / (2.0 * ACCEL_XY_MPS2) + speed + 2.0 * STEP_M + STOP_MARGIN_M
        room = horizontal_room(fence, north, east, un, ue, lookahead)
        if room < lookahead:
            along = _approach(speed, room)
            out_n, out_e = un * along, ue * along
    ceiling, floor = params["GF_MAX_VER_DIST"], params["GF_MIN_ALT"]
    if vd < 0 and ceiling > 0:
        out_d = -_vertical(-vd, ceiling - alt_m)
    elif vd > 0 and floor > 0:
        out_d = _vertical(vd, alt_m - floor)
    limited = abs(out_n - vn) + abs(out_e - ve) + abs(out_d - vd) > 1e-3
    return Limited(out_n, out_e, out_d, limited)


def _vertical(rate: float, room_m: float) -> float:
    d = room_m - STOP_MARGIN_M
    if d <= 0:
        return max(GAIN_PER_S * d, -MAX_BACKOFF_MPS)
    return min(rate, math.sqrt(2.0 * ACCEL_Z_MPS2 * d), GAIN_PER_S * d)
