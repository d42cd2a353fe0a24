"""A cascaded multicopter flight controller: position → velocity → attitude → body-rate targets.

The F450's own flight control system closes the body-rate loop (see :mod:`flight.sim.jsbsim_model`); this module
closes everything above it, in plain Python floats (the loops run thousands of times per simulated minute, and
small numpy arrays would cost more than they save):

* **position** (P, per axis): a velocity setpoint towards the target, shaped so it never asks for more than the
  deceleration the vehicle can give (``v = min(kp·d, sqrt(2·a·d))`` along the line to the target) and capped by the
  horizontal speed limit (or the setpoint's own speed) and the climb/descent limits;
* **velocity** (PI with derivative on the measurement, per axis; the integrators are clamped and only run in the
  air): an acceleration setpoint in NED;
* **thrust and tilt**: the horizontal acceleration becomes roll and pitch setpoints at the current heading, limited
  to ``max_tilt_rad``; the vertical acceleration becomes collective throttle through the hover throttle and a power
  law (thrust ∝ throttle^1.5 for this propeller, measured), divided by ``cos(roll)·cos(pitch)`` so a tilted vehicle
  keeps its altitude (tilt compensation);
* **attitude and heading** (P): Euler-angle rate setpoints, converted to body rates and clipped to the ±0.75 rad/s
  the model's rate loop accepts.

Setpoints are the frozen dataclasses :class:`HoldPosition`, :class:`GoToPosition`, :class:`VelocitySetpoint` and
:class:`Land`. ``Land`` descends (fast high up, slowly near the ground) over the position where it was given and
cuts the throttle once the gear has been on the ground for ``touchdown_s``; :attr:`FlightController.landed` then
reads True.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, NamedTuple, Protocol

G = 9.80665
"""Standard gravity (m/s²)."""
THRUST_EXPONENT = 1.5
"""Static thrust of the F450's DJI 9450 propellers grows about as throttle^1.5 between 0.3 and 0.7 (measured)."""
_INV_THRUST_EXPONENT = 1.0 / THRUST_EXPONENT


class Kinematics(Protocol):
    """What the controller reads from the vehicle (SI units, NED relative to home)."""

    @property
    def north_m(self) -> float: ...
    @property
    def east_m(self) -> float: ...
    @property
    def down_m(self) -> float: ...
    @property
    def vn_mps(self) -> float: ...
    @property
    def ve_mps(self) -> float: ...
    @property
    def vd_mps(self) -> float: ...
    @property
    def roll_rad(self) -> float: ...
    @property
    def pitch_rad(self) -> float: ...
    @property
    def yaw_rad(self) -> float: ...
    @property
    def alt_agl_m(self) -> float: ...
    @property
    def on_ground(self) -> bool: ...


@dataclass(frozen=True, slots=True)
class HoldPosition:
    """Hold where the vehicle is when the setpoint is given (position and heading)."""


@dataclass(frozen=True, slots=True)
class GoToPosition:
    """Fly to a NED position (m, relative to home) and hold there. ``yaw_rad`` None keeps the current heading."""

    north_m: float
    east_m: float
    down_m: float
    yaw_rad: float | None = None
    speed_mps: float | None = None
    """Horizontal cruise speed; None means the controller's limit."""


@dataclass(frozen=True, slots=True)
class VelocitySetpoint:
    """Fly at a NED velocity (m/s). ``yaw_rad`` None keeps the current heading."""

    vn_mps: float
    ve_mps: float
    vd_mps: float
    yaw_rad: float | None = None


@dataclass(frozen=True, slots=True)
class Land:
    """Descend over the current position, touch down and cut the throttle."""


Setpoint = HoldPosition | GoToPosition | VelocitySetpoint | Land


@dataclass(frozen=True, slots=True)
class Gains:
    """Loop gains (SI units). Tuned by experiment on the JSBSim F450 at a 50 Hz controller rate."""

    pos_xy: float = 0.8
    """Horizontal position P: (m/s) per m."""
    pos_z: float = 1.2
    """Vertical position P: (m/s) per m."""
    vel_xy_p: float = 2.5
    """Horizontal velocity P: (m/s²) per (m/s)."""
    vel_xy_i: float = 0.4
    vel_xy_d: float = 0.05
    vel_z_p: float = 3.0
    vel_z_i: float = 1.0
    att: float = 5.0
    """Attitude P: (rad/s) per rad."""
    yaw: float = 2.0
    """Heading P: (rad/s) per rad."""


@dataclass(frozen=True, slots=True)
class Limits:
    """Speed, tilt and integrator limits."""

    max_speed_xy_mps: float = 8.0
    max_climb_mps: float = 3.0
    max_descent_mps: float = 1.5
    max_accel_xy_mps2: float = 2.0
    """The deceleration assumed when shaping the approach to a position target."""
    max_tilt_rad: float = math.radians(30.0)
    max_rate_rps: float = 0.75
    """The model's rate loop saturates at 0.75 rad/s."""
    max_yaw_rate_rps: float = 0.6
    int_xy_mps2: float = 2.0
    """Clamp on the horizontal velocity integrators' contribution (m/s²)."""
    int_z_mps2: float = 3.0
    """Clamp on the vertical velocity integrator's contribution (m/s²)."""
    min_throttle_air: float = 0.08
    idle_throttle: float = 0.1
    """Collective while armed and sitting on the ground with nowhere higher to go (props spinning, no lift)."""
    land_speed_fast_mps: float = 1.2
    land_speed_slow_mps: float = 0.4
    land_slow_below_m: float = 3.0
    touchdown_s: float = 0.3


class ControlOutput(NamedTuple):
    """Collective throttle ``[0, 1]`` and body-rate targets (rad/s) for the model's rate loop."""

    throttle: float
    p_rps: float
    q_rps: float
    r_rps: float


IDLE = ControlOutput(0.0, 0.0, 0.0, 0.0)
_new_output = tuple.__new__
"""Builds a :class:`ControlOutput` from a tuple of its four fields without the named tuple's Python-level
``__new__`` (one is built every control tick)."""


def _clip(x: float, lo: float, hi: float) -> float:
    return lo if x < lo else hi if x > hi else x


def _wrap_pi(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


@dataclass(slots=True)
class _Target:
    north: float = 0.0
    east: float = 0.0
    down: float = 0.0
    yaw: float = 0.0
    speed: float | None = None
    vn: float = 0.0
    ve: float = 0.0
    vd: float = 0.0
    position_mode: bool = True


@dataclass(frozen=True, slots=True)
class _Derived:
    """Values computed from the gains and limits alone, once per pair rather than on every update."""

    gains: Gains
    limits: Limits
    int_xy: float
    """Clamp on each horizontal velocity integrator (the integrator itself, not its contribution)."""
    int_z: float
    amax: float
    """The horizontal acceleration the tilt limit allows (m/s²)."""
    climb_lo: float
    tilt_lo: float
    yaw_rate_lo: float
    rate_lo: float
    ground_idle: ControlOutput

    @classmethod
    def of(cls, g: Gains, lim: Limits) -> _Derived:
        return cls(
            g,
            lim,
            int_xy=lim.int_xy_mps2 / g.vel_xy_i if g.vel_xy_i > 0 else 0.0,
            int_z=lim.int_z_mps2 / g.vel_z_i if g.vel_z_i > 0 else 0.0,
            amax=G * math.tan(lim.max_tilt_rad),
            climb_lo=-lim.max_climb_mps,
            tilt_lo=-lim.max_tilt_rad,
            yaw_rate_lo=-lim.max_yaw_rate_rps,
            rate_lo=-lim.max_rate_rps,
            ground_idle=ControlOutput(lim.idle_throttle, 0.0, 0.0, 0.0),
        )


@dataclass(slots=True)
class _LoopState:
    int_n: float = 0.0
    int_e: float = 0.0
    int_d: float = 0.0
    prev_vn: float | None = None
    prev_ve: float | None = None
    ground_time: float = 0.0


class FlightController:
    """The cascade above the model's rate loop. Call :meth:`update` at a fixed rate with the vehicle's state."""

    def __init__(self, gains: Gains | None = None, limits: Limits | None = None, hover_throttle: float = 0.41) -> None:
        self.gains = gains or Gains()
        self.limits = limits or Limits()
        self.hover_throttle = hover_throttle
        self._setpoint: Setpoint = HoldPosition()
        self._landing = False
        """The setpoint is a :class:`Land` (checked on every update)."""
        self._target = _Target()
        self._loop = _LoopState()
        self._landed = False
        self._derived: _Derived | None = None

    @property
    def setpoint(self) -> Setpoint:
        """The setpoint being flown (``HoldPosition`` resolved to where it was given)."""
        return self._setpoint

    @property
    def landed(self) -> bool:
        """True once a :class:`Land` setpoint has touched down and cut the throttle."""
        return self._landed

    @property
    def target_position(self) -> tuple[float, float, float] | None:
        """The NED position being held or flown to, or None in velocity mode."""
        t = self._target
        return (t.north, t.east, t.down) if t.position_mode else None

    def memory(self) -> dict[str, Any]:
        """What the controller remembers between updates, besides its gains and limits (for a snapshot): the
        setpoint, the resolved target, the loop state (integrators, last velocities) and whether it has landed."""
        return {
            "setpoint": self._setpoint,
            "target": dataclasses.asdict(self._target),
            "loop": dataclasses.asdict(self._loop),
            "landed": self._landed,
        }

    def recall(self, setpoint: Setpoint, target: dict[str, Any], loop: dict[str, Any], landed: bool) -> None:
        """Take up :meth:`memory`'s values again (on resuming a snapshot)."""
        self._setpoint = setpoint
        self._landing = isinstance(setpoint, Land)
        self._target = _Target(**target)
        self._loop = _LoopState(**loop)
        self._landed = landed

    def reset(self) -> None:
        """Clear integrators and touchdown state (on arming)."""
        self._loop = _LoopState()
        self._landed = False

    def set_setpoint(self, setpoint: Setpoint, state: Kinematics) -> None:
        """Fly ``setpoint`` from now on; ``state`` resolves "here" for hold, land and kept headings."""
        t = _Target(yaw=state.yaw_rad)
        if isinstance(setpoint, HoldPosition | Land):
            t.north, t.east, t.down = state.north_m, state.east_m, state.down_m
        elif isinstance(setpoint, GoToPosition):
            t.north, t.east, t.down = setpoint.north_m, setpoint.east_m, setpoint.down_m
            t.speed = setpoint.speed_mps
            if setpoint.yaw_rad is not None:
                t.yaw = setpoint.yaw_rad
        else:
            t.position_mode = False
            t.vn, t.ve, t.vd = setpoint.vn_mps, setpoint.ve_mps, setpoint.vd_mps
            if setpoint.yaw_rad is not None:
                t.yaw = setpoint.yaw_rad
        if not isinstance(setpoint, Land):
            self._landed = False
            self._loop.ground_time = 0.0
        self._setpoint = setpoint
        self._landing = isinstance(setpoint, Land)
        self._target = t

    def update(self, s: Kinematics, dt: float) -> ControlOutput:
        """One controller step of ``dt`` seconds: the throttle and body-rate targets to hold until the next."""
        g, lim, t, loop = self.gains, self.limits, self._target, self._loop
        k = self._derived
        if k is None or k.gains is not g or k.limits is not lim:
            k = self._derived = _Derived.of(g, lim)
        landing = self._landing
        on_ground = s.on_ground
        if landing:
            if self._landed:
                return IDLE
            if on_ground:
                loop.ground_time += dt
                if loop.ground_time >= lim.touchdown_s:
                    self._landed = True
                    return IDLE
            else:
                loop.ground_time = 0.0

        # Position → velocity setpoint.
        if t.position_mode:
            dn, de = t.north - s.north_m, t.east - s.east_m
            dist = math.hypot(dn, de)
            vmax = lim.max_speed_xy_mps if t.speed is None else min(t.speed, lim.max_speed_xy_mps)
            if dist > 1e-6:
                v = min(g.pos_xy * dist, math.sqrt(2.0 * lim.max_accel_xy_mps2 * dist), vmax)
                vn_sp, ve_sp = v * dn / dist, v * de / dist
            else:
                vn_sp = ve_sp = 0.0
            if landing:
                vd_sp = lim.land_speed_fast_mps if s.alt_agl_m > lim.land_slow_below_m else lim.land_speed_slow_mps
            else:
                vd_sp = _clip(g.pos_z * (t.down - s.down_m), k.climb_lo, lim.max_descent_mps)
        else:
            vn_sp, ve_sp = t.vn, t.ve
            sp = math.hypot(vn_sp, ve_sp)
            if sp > lim.max_speed_xy_mps:
                vn_sp, ve_sp = vn_sp * lim.max_speed_xy_mps / sp, ve_sp * lim.max_speed_xy_mps / sp
            vd_sp = _clip(t.vd, k.climb_lo, lim.max_descent_mps)

        airborne = not on_ground
        if not airborne and vd_sp >= 0.0:
            # Armed on the ground with nowhere higher to go: spin at idle, keep the integrators empty.
            loop.int_n = loop.int_e = loop.int_d = 0.0
            return k.ground_idle

        # Velocity → acceleration setpoint (NED).
        vn, ve = s.vn_mps, s.ve_mps
        en, ee, ed = vn_sp - vn, ve_sp - ve, vd_sp - s.vd_mps
        if airborne:
            ix = k.int_xy
            x = loop.int_n + en * dt
            loop.int_n = -ix if x < -ix else ix if x > ix else x
            x = loop.int_e + ee * dt
            loop.int_e = -ix if x < -ix else ix if x > ix else x
        iz = k.int_z
        x = loop.int_d + ed * dt
        loop.int_d = -iz if x < -iz else iz if x > iz else x
        prev_vn, prev_ve = loop.prev_vn, loop.prev_ve
        dvn = 0.0 if prev_vn is None else (vn - prev_vn) / dt
        dve = 0.0 if prev_ve is None else (ve - prev_ve) / dt
        loop.prev_vn, loop.prev_ve = vn, ve
        an = g.vel_xy_p * en + g.vel_xy_i * loop.int_n - g.vel_xy_d * dvn
        ae = g.vel_xy_p * ee + g.vel_xy_i * loop.int_e - g.vel_xy_d * dve
        ad = g.vel_z_p * ed + g.vel_z_i * loop.int_d
        amax = k.amax
        ah = math.hypot(an, ae)
        if ah > amax:
            an, ae = an * amax / ah, ae * amax / ah

        # Acceleration → attitude and collective (with tilt compensation).
        roll, pitch, yaw = s.roll_rad, s.pitch_rad, s.yaw_rad
        cy, sy = math.cos(yaw), math.sin(yaw)
        a_fwd = cy * an + sy * ae
        a_right = -sy * an + cy * ae
        if not airborne:
            a_fwd = a_right = 0.0  # lifting off: keep level until the gear is clear
        pitch_sp = math.atan2(-a_fwd, G)
        roll_sp = math.atan2(a_right * math.cos(pitch_sp), G)
        tilt_lim, tilt_lo = lim.max_tilt_rad, k.tilt_lo
        pitch_sp = tilt_lo if pitch_sp < tilt_lo else tilt_lim if pitch_sp > tilt_lim else pitch_sp
        roll_sp = tilt_lo if roll_sp < tilt_lo else tilt_lim if roll_sp > tilt_lim else roll_sp
        lift = max(0.0, 1.0 - ad / G)
        sphi, cphi = math.sin(roll), math.cos(roll)
        sth, cth = math.sin(pitch), math.cos(pitch)
        tilt_cos = max(0.5, cphi * cth)
        throttle = self.hover_throttle * (lift / tilt_cos) ** _INV_THRUST_EXPONENT
        throttle = _clip(throttle, lim.min_throttle_air if airborne else 0.0, 1.0)

        # Attitude and heading → body rates.
        phi_dot = g.att * (roll_sp - roll)
        theta_dot = g.att * (pitch_sp - pitch)
        psi_dot = _clip(g.yaw * _wrap_pi(t.yaw - yaw), k.yaw_rate_lo, lim.max_yaw_rate_rps)
        p = phi_dot - sth * psi_dot
        q = cphi * theta_dot + sphi * cth * psi_dot
        r = -sphi * theta_dot + cphi * cth * psi_dot
        mr, lo = lim.max_rate_rps, k.rate_lo
        return _new_output(
            ControlOutput,
            (
                throttle,
                lo if p < lo else mr if p > mr else p,
                lo if q < lo else mr if q > mr else q,
                lo if r < lo else mr if r > mr else r,
            ),
        )
