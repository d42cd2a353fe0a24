"""The simulated vehicle: JSBSim F450 + flight controller + battery + environment, stepped in lockstep.

:class:`Simulator` owns one :class:`~flight.sim.jsbsim_model.F450Model` and advances it 1/250 s per step. Every
``250 / controller_rate_hz`` steps (a *control tick*, 50 Hz by default) it runs the flight controller, the battery
and the gust process and holds their outputs until the next tick; GPS errors are drawn at the GPS rate. Nothing
here reads a clock: the caller decides how fast simulated time passes (``step``/``run_for`` for lockstep; a real-time
pacer can call ``step`` from a timer). All randomness comes from one seed, so two simulators built alike and
driven alike produce identical states.

Arming engages the model's rate loop; disarming stops the motors. A :class:`~flight.sim.controller.Land` setpoint
disarms the vehicle once it has touched down, as PX4 does. The payload is a flag (released or not): the F450 model
has no point mass to drop.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from pydantic import BaseModel, ConfigDict

from flight.geodesy import geodetic_to_ned, ned_to_geodetic
from flight.sim import snapshot
from flight.sim.battery import Battery, BatteryConfig
from flight.sim.controller import (
    IDLE,
    ControlOutput,
    FlightController,
    Gains,
    GoToPosition,
    HoldPosition,
    Land,
    Limits,
    Setpoint,
    VelocitySetpoint,
)
from flight.sim.environment import Environment, GpsNoise, Gusts, NormalStream, WindSettings
from flight.sim.jsbsim_model import DT, HOVER_THROTTLE, F450Model, ModelState
from flight.sim.snapshot import SimSnapshot

STEPS_PER_SECOND = round(1.0 / DT)


class VehicleState(BaseModel):
    """A snapshot of the simulated vehicle (true state; see :class:`GpsFix` for what a GPS receiver reports)."""

    model_config = ConfigDict(frozen=True)

    time_s: float
    lat_deg: float
    lon_deg: float
    alt_msl_m: float
    alt_agl_m: float
    north_m: float
    east_m: float
    down_m: float
    vn_mps: float
    ve_mps: float
    vd_mps: float
    roll_rad: float
    pitch_rad: float
    yaw_rad: float
    battery_pct: float
    battery_voltage_v: float
    battery_current_a: float
    throttle: float
    """Collective throttle commanded at the last control tick."""
    armed: bool
    landed: bool
    """The gear is on the ground."""
    payload_released: bool
    setpoint: str
    """The kind of setpoint being flown (``HoldPosition``, ``GoToPosition``, …) or ``Disarmed``."""

    @property
    def groundspeed_mps(self) -> float:
        return math.hypot(self.vn_mps, self.ve_mps)


ConditionFn = Callable[[VehicleState], bool]
"""A predicate on the vehicle's state, for :meth:`Simulator.run_until`."""


class GpsFix(BaseModel):
    """What the simulated GPS receiver reports: the true position plus the environment's error model."""

    model_config = ConfigDict(frozen=True)

    time_s: float
    lat_deg: float
    lon_deg: float
    alt_msl_m: float
    vn_mps: float
    ve_mps: float
    vd_mps: float
    eph_m: float
    epv_m: float
    satellites: int
    fix_type: int = 3


class Simulator:
    """The F450 with its flight controller, battery and environment. Not thread-safe: one caller steps it."""

    def __init__(
        self,
        environment: Environment | None = None,
        battery: BatteryConfig | None = None,
        gains: Gains | None = None,
        limits: Limits | None = None,
        seed: int = 0,
        controller_rate_hz: int = 50,
    ) -> None:
        if controller_rate_hz <= 0 or STEPS_PER_SECOND % controller_rate_hz:
            raise ValueError(f"controller_rate_hz must divide {STEPS_PER_SECOND}")
        self.environment = environment or Environment()
        home = self.environment.home
        self.model = F450Model(home.lat_deg, home.lon_deg, home.alt_msl_m, home.heading_deg)
        self.controller = FlightController(gains, limits, hover_throttle=HOVER_THROTTLE)
        self.battery = Battery(battery)
        self.seed = seed
        gust_seq, gps_seq = np.random.SeedSequence(seed).spawn(2)
        self._gust_rng = np.random.default_rng(gust_seq)
        self.gps = GpsNoise(self.environment.gps, NormalStream(np.random.default_rng(gps_seq)))
        self._steps_per_tick = STEPS_PER_SECOND // controller_rate_hz
        self._tick_dt = self._steps_per_tick * DT
        self._phase = 0
        self._steps = 0
        self._gps_countdown = 0.0
        self._armed = False
        self._payload_released = False
        self._output: ControlOutput = IDLE
        self._wind = self.environment.wind
        self._gust_normals = NormalStream(self._gust_rng)  # every gust draw goes through it: same values, cheaper
        self._gusts = Gusts(self._wind, self._gust_normals)
        self.model.set_wind(self._wind.north_mps, self._wind.east_mps, self._wind.down_mps)
        self._truth: ModelState = self.model.state()
        self._truth_steps = self._steps
        """The step count at which ``_truth`` was read: a control tick right after a step reuses it."""
        self._version = 0
        """Bumped by everything that can change :meth:`state` (steps, arming, setpoints, payload)."""
        self._state_cache: tuple[int, float, VehicleState] | None = None
        self.gps_lost = False
        """An injected GPS failure: :meth:`gps_fix` reports no fix (the flight model flies on regardless)."""
        self.motors_failed: frozenset[int] = frozenset()
        """Motors (0..3) whose output an injected failure holds at zero (:meth:`fail_motor`)."""

    # -- time ------------------------------------------------------------------------------------------------

    @property
    def dt(self) -> float:
        """Seconds per step (1/250)."""
        return DT

    @property
    def time_s(self) -> float:
        """Simulated seconds since start."""
        return self._steps * DT

    def step(self, n: int = 1) -> None:
        """Advance ``n`` physics steps of 1/250 s, running the control tick whenever one falls due."""
        if n < 0:
            raise ValueError("n must be >= 0")
        model = self.model
        while n > 0:
            if self._phase == 0:
                self._control_tick()
            chunk = min(n, self._steps_per_tick - self._phase)
            model.step(chunk)
            n -= chunk
            self._steps += chunk
            self._phase = (self._phase + chunk) % self._steps_per_tick
        self._truth = model.state()
        self._truth_steps = self._steps
        self._version += 1

    def run_for(self, seconds: float) -> None:
        """Advance ``seconds`` of simulated time (rounded to whole steps)."""
        self.step(round(seconds * STEPS_PER_SECOND))

    def run_until(self, done: ConditionFn, timeout_s: float, check_every_s: float = 0.1) -> bool:
        """Step until ``done(state)`` is true (checked every ``check_every_s``) or ``timeout_s`` passes."""
        chunk = max(1, round(check_every_s * STEPS_PER_SECOND))
        end = self._steps + round(timeout_s * STEPS_PER_SECOND)
        while self._steps < end:
            self.step(min(chunk, end - self._steps))
            if done(self.state()):
                return True
        return False

    def _control_tick(self) -> None:
        if self._truth_steps != self._steps:  # else the state read at the end of the last step() is still current
            self._truth = self.model.state()
            self._truth_steps = self._steps
        truth = self._truth
        dt = self._tick_dt
        if self._armed:
            out = self.controller.update(truth, dt)
            if self.controller.landed:
                self.disarm()
                out = IDLE
        else:
            out = IDLE
        self._output = out
        self.model.set_controls(out.throttle, out.p_rps, out.q_rps, out.r_rps)
        self.battery.update(truth.motor_outputs, dt)
        gn, ge, gd = self._gusts.step(dt)
        if gn or ge or gd:
            self.model.set_gust(gn, ge, gd)
        self._gps_countdown -= dt
        if self._gps_countdown <= 1e-9:
            self.gps.step()
            self._gps_countdown += self.gps.period_s

    # -- commands --------------------------------------------------------------------------------------------

    @property
    def armed(self) -> bool:
        return self._armed

    def arm(self) -> bool:
        """Arm on the ground (motors spin at idle, holding the ground position). False if it cannot."""
        if self._armed:
            return True
        if self.battery.depleted or not self._truth.on_ground:
            return False
        self.controller.reset()
        self.controller.set_setpoint(HoldPosition(), self._truth)
        self.model.set_engaged(True)
        self._armed = True
        self._version += 1
        return True

    def disarm(self, force: bool = False) -> bool:
        """Stop the motors. Refused in the air unless ``force`` (which drops the aircraft)."""
        if not self._armed:
            return True
        if not self._truth.on_ground and not force:
            return False
        self._armed = False
        self._output = IDLE
        self.model.set_controls(0.0, 0.0, 0.0, 0.0)
        self.model.set_engaged(False)
        self._version += 1
        return True

    def set_setpoint(self, setpoint: Setpoint) -> bool:
        """Fly ``setpoint`` from the next control tick. False (ignored) when disarmed."""
        if not self._armed:
            return False
        self.controller.set_setpoint(setpoint, self._truth)
        self._version += 1
        return True

    def takeoff(self, altitude_m: float) -> bool:
        """Climb straight up to ``altitude_m`` above home and hold."""
        s = self._truth
        return self.set_setpoint(GoToPosition(s.north_m, s.east_m, -altitude_m))

    def hold(self) -> bool:
        return self.set_setpoint(HoldPosition())

    def goto(
        self, north_m: float, east_m: float, down_m: float, yaw_rad: float | None = None, speed_mps: float | None = None
    ) -> bool:
        """Fly to a NED position relative to home."""
        return self.set_setpoint(GoToPosition(north_m, east_m, down_m, yaw_rad, speed_mps))

    def goto_global(
        self,
        lat_deg: float,
        lon_deg: float,
        alt_msl_m: float,
        yaw_rad: float | None = None,
        speed_mps: float | None = None,
    ) -> bool:
        """Fly to a geodetic position (altitude above mean sea level)."""
        home = self.environment.home
        n, e, d = geodetic_to_ned(lat_deg, lon_deg, alt_msl_m, home.lat_deg, home.lon_deg, home.alt_msl_m)
        return self.goto(n, e, d, yaw_rad, speed_mps)

    def set_velocity(self, vn_mps: float, ve_mps: float, vd_mps: float, yaw_rad: float | None = None) -> bool:
        return self.set_setpoint(VelocitySetpoint(vn_mps, ve_mps, vd_mps, yaw_rad))

    def land(self) -> bool:
        """Descend where the vehicle is, touch down, cut the motors and disarm."""
        return self.set_setpoint(Land())

    def fail_motor(self, index: int, failed: bool = True) -> None:
        """Stop motor ``index`` (0..3: front right, aft left, front left, aft right) whatever the controller asks,
        or give it back; the controller does not know (a quadrotor cannot fly on three motors)."""
        if not 0 <= index < 4:
            raise ValueError(f"motor index must be 0..3, not {index}")
        self.model.set_motor_failed(index, failed)
        self.motors_failed = self.motors_failed | {index} if failed else self.motors_failed - {index}
        self._version += 1

    def release_payload(self) -> bool:
        """Release the payload. False if it was already released."""
        if self._payload_released:
            return False
        self._payload_released = True
        self._version += 1
        return True

    @property
    def payload_released(self) -> bool:
        return self._payload_released

    def set_wind(self, wind: WindSettings) -> None:
        """Change the wind from now on (steady part at once, gusts from the next control tick)."""
        self._wind = wind
        self._gusts = Gusts(wind, self._gust_normals)
        self.model.set_wind(wind.north_mps, wind.east_mps, wind.down_mps)
        self.model.set_gust(0.0, 0.0, 0.0)

    @property
    def wind(self) -> WindSettings:
        return self._wind

    # -- snapshots -------------------------------------------------------------------------------------------

    def snapshot(self) -> SimSnapshot:
        """Everything needed to carry this flight on in a fresh simulator (JSON with ``model_dump_json``), e.g.
        ``Simulator.from_snapshot(SimSnapshot.from_json(text))`` in another process (the examples are in
        :mod:`flight.sim.snapshot`)."""
        return snapshot.take(self)

    def restore(self, snap: SimSnapshot) -> None:
        """Become the simulator ``snap`` was taken from, in its state (its settings replace this one's); in the
        air or on the ground. A bad snapshot raises :class:`~flight.sim.snapshot.SnapshotError`, leaving this
        simulator as it was."""
        snap = snapshot.checked(snap)
        self.__init__(**snapshot.settings(snap))  # type: ignore[misc]
        snapshot.apply(self, snap)

    @classmethod
    def from_snapshot(cls, snap: SimSnapshot) -> Simulator:
        """A new simulator in the snapshot's state (see :meth:`restore`)."""
        snap = snapshot.checked(snap)
        sim = cls(**snapshot.settings(snap))
        snapshot.apply(sim, snap)
        return sim

    # -- observation -----------------------------------------------------------------------------------------

    def truth(self) -> ModelState:
        """The model's raw SI state (as of the last step)."""
        return self._truth

    def state(self) -> VehicleState:
        """The current snapshot. Built once per change (several readers ask every tick; building one validates 23
        fields), keyed on everything that changes it, including a battery drained from outside."""
        cache = self._state_cache
        soc = self.battery.soc
        if cache is not None and cache[0] == self._version and cache[1] == soc:
            return cache[2]
        state = self._build_state()
        self._state_cache = (self._version, soc, state)
        return state

    def _build_state(self) -> VehicleState:
        s = self._truth
        b = self.battery
        return VehicleState(
            time_s=self.time_s,
            lat_deg=s.lat_deg,
            lon_deg=s.lon_deg,
            alt_msl_m=s.alt_msl_m,
            alt_agl_m=s.alt_agl_m,
            north_m=s.north_m,
            east_m=s.east_m,
            down_m=s.down_m,
            vn_mps=s.vn_mps,
            ve_mps=s.ve_mps,
            vd_mps=s.vd_mps,
            roll_rad=s.roll_rad,
            pitch_rad=s.pitch_rad,
            yaw_rad=s.yaw_rad,
            battery_pct=b.percent,
            battery_voltage_v=b.voltage_v,
            battery_current_a=b.current_a,
            throttle=self._output.throttle,
            armed=self._armed,
            landed=s.on_ground,
            payload_released=self._payload_released,
            setpoint=type(self.controller.setpoint).__name__ if self._armed else "Disarmed",
        )

    def gps_fix(self) -> GpsFix:
        """The latest GPS report (errors change at the GPS rate)."""
        s = self._truth
        home = self.environment.home
        en, ee, ed = self.gps.position_error
        lat, lon, alt = ned_to_geodetic(
            s.north_m + en, s.east_m + ee, s.down_m + ed, home.lat_deg, home.lon_deg, home.alt_msl_m
        )
        vn, ve, vd = self.gps.velocity_error
        cfg = self.gps.settings
        return GpsFix(
            time_s=self.time_s,
            lat_deg=lat,
            lon_deg=lon,
            alt_msl_m=alt,
            vn_mps=s.vn_mps + vn,
            ve_mps=s.ve_mps + ve,
            vd_mps=s.vd_mps + vd,
            eph_m=cfg.horizontal_std_m,
            epv_m=cfg.vertical_std_m,
            satellites=0 if self.gps_lost else cfg.satellites,
            fix_type=0 if self.gps_lost else 3,
        )
