"""COMMAND_LONG (76) and COMMAND_INT (75): decode, carry out, answer with a MAV_RESULT for COMMAND_ACK (77).

Why: the command protocol is how every client arms, takes off, changes mode and flies the vehicle, and a client
waits for the ACK of each command, so every command (supported or not) gets exactly one answer: a refusal is
DENIED or TEMPORARILY_REJECTED with a STATUSTEXT saying why, an unknown command is UNSUPPORTED.

Facts relied on (MAVLink ``common.xml`` as generated into pymavlink's ``dialects/v20/common.py``):

* MAV_RESULT: ACCEPTED 0, TEMPORARILY_REJECTED 1, DENIED 2, UNSUPPORTED 3, FAILED 4.
* Command ids and parameters: NAV_RETURN_TO_LAUNCH 20; NAV_LAND 21; NAV_TAKEOFF 22 (param4 yaw in degrees,
  param7 altitude); DO_SET_MODE 176 (param1 base mode, param2 PX4 main mode, param3 PX4 sub mode);
  DO_CHANGE_SPEED 178 (param1 speed type 0 air / 1 ground / 2 climb / 3 descent, param2 m/s, -1 no change);
  DO_SET_SERVO 183 (param1 instance, param2 PWM µs); DO_REPOSITION 192 (param1 ground speed, -1 default;
  param2 MAV_DO_REPOSITION_FLAGS; param4 yaw, NaN keep; param5/6 latitude/longitude; param7 altitude);
  DO_GRIPPER 211 (param2 GRIPPER_ACTION: RELEASE 0, GRAB 1, HOLD 2); COMPONENT_ARM_DISARM 400 (param1 1 arm,
  0 disarm; param2 21196 forces); GET_HOME_POSITION 410; GET_MESSAGE_INTERVAL 510; SET_MESSAGE_INTERVAL 511
  (param1 message id, param2 interval µs, -1 off, 0 default); REQUEST_MESSAGE 512 (param1 message id);
  REQUEST_AUTOPILOT_CAPABILITIES 520; INJECT_FAILURE 420 (param1 unit, param2 type, param3 instance, param4 our
  battery level: :mod:`flight.mavlink.failures`).
* COMMAND_INT carries param5/param6 as ``int32`` degrees×1e7 in ``x``/``y`` (INT32_MAX: unset) and param7 as
  ``z``, interpreted in ``frame``: MAV_FRAME_GLOBAL 0 and GLOBAL_INT 5 are above mean sea level,
  GLOBAL_RELATIVE_ALT 3 and GLOBAL_RELATIVE_ALT_INT 6 above home, GLOBAL_TERRAIN_ALT 10 / _INT 11 above terrain
  (the same as above home here: the ground is flat).
* PX4 reads the altitude of a COMMAND_LONG NAV_TAKEOFF / DO_REPOSITION as above mean sea level; NaN takes the
  ``MIS_TAKEOFF_ALT`` parameter (take-off) or keeps the current altitude (reposition).
* PX4 reads DO_REPOSITION's yaw (param4) in **radians**: its navigator copies param4 straight into the position
  setpoint's yaw, which is in radians, although ``common.xml`` gives the field in degrees. MAVSDK follows PX4
  (``goto_location`` converts its ``yaw_deg`` to radians), so we read radians too. NAV_TAKEOFF's param4 is read in
  degrees as ``common.xml`` says (PX4 1.14 ignores it).

A forced disarm (param2 21196) while flying is carried out only for a command signed with the vehicle's key
(:meth:`~flight.mavlink.guard.LinkGuard.may_force_disarm`); PX4 obeys it from anyone.

Payload: DO_GRIPPER RELEASE and DO_SET_SERVO with a PWM of at least :data:`PAYLOAD_RELEASE_PWM` (any instance)
release the simulator's payload; it cannot be grabbed again.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

from pymavlink.dialects.v20.common import (  # MAVLink's own constants, not restated here
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_DO_CHANGE_SPEED,
    MAV_CMD_DO_GRIPPER,
    MAV_CMD_DO_REPOSITION,
    MAV_CMD_DO_SET_MODE,
    MAV_CMD_DO_SET_SERVO,
    MAV_CMD_GET_HOME_POSITION,
    MAV_CMD_GET_MESSAGE_INTERVAL,
    MAV_CMD_INJECT_FAILURE,
    MAV_CMD_NAV_LAND,
    MAV_CMD_NAV_RETURN_TO_LAUNCH,
    MAV_CMD_NAV_TAKEOFF,
    MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES,
    MAV_CMD_REQUEST_MESSAGE,
    MAV_CMD_SET_MESSAGE_INTERVAL,
    MAV_FRAME_GLOBAL,
    MAV_FRAME_GLOBAL_INT,
    MAV_FRAME_GLOBAL_RELATIVE_ALT,
    MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
    MAV_FRAME_GLOBAL_TERRAIN_ALT,
    MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
    MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_UNSUPPORTED,
)

from flight.mavlink.failures import FailureInjector
from flight.mavlink.guard import LinkGuard
from flight.mavlink.navigator import CommandDenied, Navigator
from flight.px4 import FlightMode
from flight.sim import Simulator, geodetic_to_ned

MAVLINK_MSG_ID_AUTOPILOT_VERSION = 148
MAVLINK_MSG_ID_HOME_POSITION = 242

FORCE_MAGIC = 21196
PAYLOAD_RELEASE_PWM = 1700
INT32_MAX = 2**31 - 1

_AMSL_FRAMES = frozenset({MAV_FRAME_GLOBAL, MAV_FRAME_GLOBAL_INT})
_RELATIVE_FRAMES = frozenset(
    {
        MAV_FRAME_GLOBAL_RELATIVE_ALT,
        MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        MAV_FRAME_GLOBAL_TERRAIN_ALT,
        MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
    }
)

GRIPPER_ACTION_RELEASE = 0
GRIPPER_ACTION_GRAB = 1


@dataclass(frozen=True, slots=True)
class CommandRequest:
    """A COMMAND_LONG or COMMAND_INT, normalised: ``params[4]``/``params[5]`` are degrees (NaN when unset)."""

    command: int
    params: tuple[float, float, float, float, float, float, float]
    frame: int | None = None
    """None for COMMAND_LONG (altitudes above mean sea level, as PX4)."""

    @property
    def is_int(self) -> bool:
        return self.frame is not None

    @classmethod
    def from_long(cls, msg: Any) -> CommandRequest:
        return cls(
            int(msg.command),
            (msg.param1, msg.param2, msg.param3, msg.param4, msg.param5, msg.param6, msg.param7),
        )

    @classmethod
    def from_int(cls, msg: Any) -> CommandRequest:
        lat = math.nan if msg.x == INT32_MAX else msg.x / 1e7
        lon = math.nan if msg.y == INT32_MAX else msg.y / 1e7
        return cls(int(msg.command), (msg.param1, msg.param2, msg.param3, msg.param4, lat, lon, msg.z), int(msg.frame))


@dataclass(slots=True)
class CommandOutcome:
    """The MAV_RESULT for the ACK and messages to send to the requester after it."""

    result: int
    replies: list[Any] = field(default_factory=list)


class CommandContext(Protocol):
    """What command handling needs from the vehicle (implemented by :class:`~flight.mavlink.MavlinkVehicle`)."""

    sim: Simulator
    navigator: Navigator
    failures: FailureInjector
    guard: LinkGuard
    """Whether the command in hand came signed (a forced disarm in the air needs it)."""

    def statustext(self, text: str, severity: int = ...) -> None: ...
    def set_message_interval(self, message_id: int, interval_us: float) -> bool: ...
    def message_interval_us(self, message_id: int) -> int | None: ...
    def build_message(self, message_id: int, param2: float = ...) -> Any | None: ...
    def build_message_interval(self, message_id: int, interval_us: int) -> Any: ...


Handler = Callable[[CommandContext, CommandRequest], CommandOutcome]


def handle_command(ctx: CommandContext, req: CommandRequest) -> CommandOutcome:
    """Carry out ``req``; refusals also go out as a STATUSTEXT. Never raises for a bad argument."""
    handler = HANDLERS.get(req.command)
    if handler is None:
        return CommandOutcome(MAV_RESULT_UNSUPPORTED)
    try:
        return handler(ctx, req)
    except CommandDenied as denied:
        ctx.statustext(denied.reason)
        return CommandOutcome(denied.result)


def _ok() -> CommandOutcome:
    return CommandOutcome(MAV_RESULT_ACCEPTED)


def _finite(x: float) -> bool:
    return math.isfinite(x)


def _yaw(deg: float) -> float | None:
    return math.radians(deg) if _finite(deg) else None


def _altitude_above_home(ctx: CommandContext, req: CommandRequest, z: float) -> float | None:
    """The altitude in ``z`` as metres above home (None when NaN); raises for a frame we cannot read."""
    if not _finite(z):
        return None
    if req.frame is None or req.frame in _AMSL_FRAMES:
        return z - ctx.sim.environment.home.alt_msl_m
    if req.frame in _RELATIVE_FRAMES:
        return z
    raise CommandDenied(f"Command denied: frame {req.frame} not supported")


def _arm_disarm(ctx: CommandContext, req: CommandRequest) -> CommandOutcome:
    arm, force = req.params[0], req.params[1] == FORCE_MAGIC
    if arm == 1:
        ctx.navigator.arm(force)
        return _ok()
    if arm == 0:
        flying = ctx.sim.armed and not ctx.sim.truth().on_ground
        if force and not ctx.guard.may_force_disarm(flying=flying):
            raise CommandDenied("Disarming denied: a forced disarm in flight needs a signed link")
        ctx.navigator.disarm(force)
        return _ok()
    raise CommandDenied("Command denied: param1 must be 0 (disarm) or 1 (arm)")


def _takeoff(ctx: CommandContext, req: CommandRequest) -> CommandOutcome:
    ctx.navigator.takeoff(_altitude_above_home(ctx, req, req.params[6]), _yaw(req.params[3]))
    return _ok()


def _land(ctx: CommandContext, req: CommandRequest) -> CommandOutcome:
    ctx.navigator.land()
    return _ok()


def _rtl(ctx: CommandContext, req: CommandRequest) -> CommandOutcome:
    ctx.navigator.return_to_launch()
    return _ok()


def _set_mode(ctx: CommandContext, req: CommandRequest) -> CommandOutcome:
    base, main, sub = req.params[0], req.params[1], req.params[2]
    if not (_finite(base) and int(base) & MAV_MODE_FLAG_CUSTOM_MODE_ENABLED):
        raise CommandDenied("Mode change denied: only PX4 custom modes are supported")
    main_i = int(main) if _finite(main) else 0
    sub_i = int(sub) if _finite(sub) else 0
    mode = FlightMode.from_px4(main_i, sub_i)
    if mode is None:
        raise CommandDenied(f"Mode change denied: mode {main_i}/{sub_i} is not available")
    ctx.navigator.set_mode(mode)
    return _ok()


def _reposition(ctx: CommandContext, req: CommandRequest) -> CommandOutcome:
    speed, _flags, _, yaw_rad, lat, lon, z = req.params
    s = ctx.sim.state()
    home = ctx.sim.environment.home
    alt_rel = _altitude_above_home(ctx, req, z)
    if alt_rel is None:
        alt_rel = -s.down_m
    if _finite(lat) and _finite(lon):
        if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
            raise CommandDenied("Reposition denied: position out of range")
        north, east, _ = geodetic_to_ned(lat, lon, home.alt_msl_m, home.lat_deg, home.lon_deg, home.alt_msl_m)
    else:
        north, east = s.north_m, s.east_m
    yaw = math.remainder(yaw_rad, math.tau) if _finite(yaw_rad) else None  # radians, as PX4 (module docstring)
    ctx.navigator.reposition(north, east, -alt_rel, yaw, speed if _finite(speed) and speed > 0 else None)
    return _ok()


def _change_speed(ctx: CommandContext, req: CommandRequest) -> CommandOutcome:
    kind, speed = req.params[0], req.params[1]
    if kind not in (0, 1):
        raise CommandDenied("Speed change denied: only horizontal (air or ground) speed can be set")
    if speed == -1 or speed == -2:  # -1 no change; -2 return to default
        if speed == -2:
            ctx.navigator.cruise_speed_mps = None
        return _ok()
    ctx.navigator.change_speed(speed)
    return _ok()


def _set_servo(ctx: CommandContext, req: CommandRequest) -> CommandOutcome:
    pwm = req.params[1]
    if not _finite(pwm):
        raise CommandDenied("Servo denied: PWM is not a number")
    if pwm >= PAYLOAD_RELEASE_PWM:
        ctx.sim.release_payload()
    return _ok()


def _gripper(ctx: CommandContext, req: CommandRequest) -> CommandOutcome:
    action = req.params[1]
    if action == GRIPPER_ACTION_RELEASE:
        ctx.sim.release_payload()
    elif action == GRIPPER_ACTION_GRAB and ctx.sim.payload_released:
        raise CommandDenied("Gripper denied: the payload has been released")
    return _ok()


def _message_id(x: float) -> int:
    if not _finite(x) or x < 0 or x != int(x):
        raise CommandDenied("Command denied: bad message id")
    return int(x)


def _get_home(ctx: CommandContext, req: CommandRequest) -> CommandOutcome:
    msg = ctx.build_message(MAVLINK_MSG_ID_HOME_POSITION)
    return CommandOutcome(MAV_RESULT_ACCEPTED, [msg])


def _request_message(ctx: CommandContext, req: CommandRequest) -> CommandOutcome:
    msg = ctx.build_message(_message_id(req.params[0]), req.params[1])
    if msg is None:
        raise CommandDenied(f"Request denied: message {req.params[0]:.0f} not available")
    return CommandOutcome(MAV_RESULT_ACCEPTED, [msg])


def _autopilot_capabilities(ctx: CommandContext, req: CommandRequest) -> CommandOutcome:
    return CommandOutcome(MAV_RESULT_ACCEPTED, [ctx.build_message(MAVLINK_MSG_ID_AUTOPILOT_VERSION)])


def _set_interval(ctx: CommandContext, req: CommandRequest) -> CommandOutcome:
    msg_id, interval = _message_id(req.params[0]), req.params[1]
    if not _finite(interval) or not ctx.set_message_interval(msg_id, interval):
        raise CommandDenied(f"Interval denied: message {msg_id} is not streamed")
    return _ok()


def _get_interval(ctx: CommandContext, req: CommandRequest) -> CommandOutcome:
    msg_id = _message_id(req.params[0])
    interval = ctx.message_interval_us(msg_id)
    if interval is None:
        raise CommandDenied(f"Interval denied: message {msg_id} is not streamed")
    return CommandOutcome(MAV_RESULT_ACCEPTED, [ctx.build_message_interval(msg_id, interval)])


def _inject_failure(ctx: CommandContext, req: CommandRequest) -> CommandOutcome:
    ctx.failures.inject(req.params[0], req.params[1], req.params[2], value=req.params[3])
    return _ok()


HANDLERS: dict[int, Handler] = {
    MAV_CMD_COMPONENT_ARM_DISARM: _arm_disarm,
    MAV_CMD_NAV_TAKEOFF: _takeoff,
    MAV_CMD_NAV_LAND: _land,
    MAV_CMD_NAV_RETURN_TO_LAUNCH: _rtl,
    MAV_CMD_DO_SET_MODE: _set_mode,
    MAV_CMD_DO_REPOSITION: _reposition,
    MAV_CMD_DO_CHANGE_SPEED: _change_speed,
    MAV_CMD_DO_SET_SERVO: _set_servo,
    MAV_CMD_DO_GRIPPER: _gripper,
    MAV_CMD_GET_HOME_POSITION: _get_home,
    MAV_CMD_REQUEST_MESSAGE: _request_message,
    MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: _autopilot_capabilities,
    MAV_CMD_SET_MESSAGE_INTERVAL: _set_interval,
    MAV_CMD_GET_MESSAGE_INTERVAL: _get_interval,
    MAV_CMD_INJECT_FAILURE: _inject_failure,
}
"""The supported commands; anything else is answered MAV_RESULT_UNSUPPORTED."""
