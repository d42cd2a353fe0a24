"""The JSBSim F450 quadcopter, wrapped: SI units in and out, NED position relative to a home point.

JSBSim ships the F450 model (``aircraft/F450``) inside the ``jsbsim`` wheel; nothing is fetched at run time. The
model's flight control system is rate-only: each of the roll, pitch and yaw sticks (``[-1, 1]``) asks its PID for a
body rate of 0.75 rad/s per unit, and the collective throttle adds to all four motors. Angle, velocity and position
loops live in :mod:`flight.sim.controller`.

Facts this wrapper relies on (checked against JSBSim 1.3.3):

* ``initGrnd`` would start the aircraft 285 m above the terrain; we set the initial conditions ourselves and put the
  gear on the ground with ``ic/h-agl-ft`` before ``run_ic()``.
* ``fcs/ScasEngage`` must be 1 or the rate sticks do nothing; we engage it while armed and disengage it when
  disarmed, so a zero throttle really stops all four motors.
* ``position/distance-from-start-*`` are unsigned, so north/east come from latitude/longitude on the WGS-84
  ellipsoid (a local tangent plane at home: ample for the few kilometres a mission covers).
* A step of 1/250 s: 1/30 s diverges and 1/120 s jitters on the ground.

JSBSim properties used (names listed from the loaded model's property catalogue, units as JSBSim names them):

* initial conditions: ``ic/lat-geod-deg``, ``ic/long-gc-deg``, ``ic/terrain-elevation-ft``, ``ic/h-agl-ft``,
  ``ic/psi-true-deg``, ``ic/phi-deg``, ``ic/theta-deg``, ``ic/vt-fps``
* inputs: ``fcs/throttle-cmd-norm[0]`` (collective), ``fcs/aileron-cmd-norm`` (roll rate),
  ``fcs/elevator-cmd-norm`` (pitch rate), ``fcs/rudder-cmd-norm`` (yaw rate), ``fcs/ScasEngage``
* wind: ``atmosphere/wind-north-fps``, ``atmosphere/wind-east-fps``, ``atmosphere/wind-down-fps`` (steady),
  ``atmosphere/gust-north-fps``, ``atmosphere/gust-east-fps``, ``atmosphere/gust-down-fps`` (gusts); both are the
  velocity the air moves *towards*, in the NED frame
* state: ``position/lat-geod-deg``, ``position/long-gc-deg``, ``position/h-sl-meters``, ``position/h-agl-ft``,
  ``position/terrain-elevation-asl-ft``, ``velocities/v-north-fps``, ``velocities/v-east-fps``,
  ``velocities/v-down-fps``, ``attitude/phi-rad``, ``attitude/theta-rad``, ``attitude/psi-rad``,
  ``velocities/p-rad_sec``, ``velocities/q-rad_sec``, ``velocities/r-rad_sec``, ``gear/wow``,
  ``fcs/throttle-pos-norm[0..3]`` (the four ESC outputs), ``simulation/sim-time-sec``
* failures: ``fcs/front-right/malfunction/fail_zero`` (and ``aft-left``, ``front-left``, ``aft-right``): the
  actuator outputs zero while set (JSBSim's actuator malfunction properties)
"""

from __future__ import annotations

import contextlib
import io
import math
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import NamedTuple

import jsbsim

from agentic_core.contracts.geodesy import earth_radii

FT = 0.3048
"""Metres per foot."""
DT = 1.0 / 250.0
"""The integration step: 250 Hz."""
RATE_PER_STICK = 0.75
"""Body-rate target (rad/s) per unit of roll/pitch/yaw stick, from the model's ``FlightControl.xml``."""
GEAR_HEIGHT_M = 0.1524
"""Distance from the centre of gravity down to the contact points (``Gear.xml``): the CG's height when landed."""
HOVER_THROTTLE = 0.41
"""Collective throttle that holds the 1.4 kg F450 in a hover (measured)."""
SPIN_UP_STEPS = 125
"""Half a second held in place (``forces/hold-down``) brings the propellers from rest to within 1 % of their
hover speed (measured: about 4950 of 4980 rpm)."""


class ModelState(NamedTuple):
    """The F450's true state in SI units.

    The reference point is the landing gear's contact point, :data:`GEAR_HEIGHT_M` below the centre of gravity, so
    a landed aircraft reads ``alt_agl_m == 0``, ``alt_msl_m`` equal to the terrain and ``down_m == 0`` at home.

    A named tuple (immutable, like :class:`~flight.sim.controller.ControlOutput`) rather than a frozen dataclass:
    one is built every control tick, and a frozen dataclass costs several times more to build.
    """

    time_s: float
    lat_deg: float
    lon_deg: float
    alt_msl_m: float
    alt_agl_m: float
    """Height of the landing gear above the terrain (0 when resting on the ground)."""
    north_m: float
    east_m: float
    down_m: float
    vn_mps: float
    ve_mps: float
    vd_mps: float
    roll_rad: float
    pitch_rad: float
    yaw_rad: float
    """Heading, wrapped to ``[-pi, pi)``."""
    p_rps: float
    q_rps: float
    r_rps: float
    on_ground: bool
    motor_outputs: tuple[float, float, float, float]
    """The four ESC commands ``[0, 1]`` after mixing (front right, aft left, front left, aft right)."""


@contextmanager
def _quiet_stdio() -> Iterator[None]:
    """Silence JSBSim's C++ banner and warnings, which go straight to file descriptors 1 and 2."""
    try:
        fds = (sys.stdout.fileno(), sys.stderr.fileno())
    except (AttributeError, OSError, ValueError):
        # Streams replaced by Python objects without descriptors (a doctest): the binding then writes to them.
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            yield
        return
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(fd) for fd in fds]
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        for fd in fds:
            os.dup2(devnull, fd)
        yield
    finally:
        for fd, old in zip(fds, saved, strict=True):
            os.dup2(old, fd)
            os.close(old)
        os.close(devnull)


def _clip(x: float, lo: float) -> float:
    """``min(1.0, max(lo, x))`` (NaN gives ``lo``), without the two builtin calls."""
    x = x if x > lo else lo
    return x if x < 1.0 else 1.0


def jsbsim_root_dir() -> str:
    """JSBSim's data folder (its aircraft, the F450 among them): beside the jsbsim module imported, wherever it was
    installed. jsbsim's own lookup searches only the site-packages folders and misses one on ``PYTHONPATH``, a
    ``.pth`` line or a ``pip install --target``."""
    here = os.path.dirname(jsbsim.__file__)
    return here if os.path.isdir(os.path.join(here, "aircraft")) else str(jsbsim.get_default_root_dir())


class F450Model:
    """One JSBSim F450 standing on the ground at a home point, stepped at 250 Hz.

    ``home_alt_msl_m`` is the terrain elevation at home (the terrain is flat at that elevation). Inputs are held
    between steps; :meth:`set_controls` takes the collective throttle ``[0, 1]`` and body-rate targets in rad/s
    (clipped to the model's ±0.75 rad/s).
    """

    def __init__(
        self,
        home_lat_deg: float,
        home_lon_deg: float,
        home_alt_msl_m: float,
        heading_deg: float = 0.0,
        root_dir: str | None = None,
    ) -> None:
        self.home_lat_deg = home_lat_deg
        self.home_lon_deg = home_lon_deg
        self.home_alt_msl_m = home_alt_msl_m
        self.heading_deg = heading_deg
        jsbsim.FGJSBBase().debug_lvl = 0  # type: ignore[no-untyped-call]
        with _quiet_stdio():
            self._fdm = jsbsim.FGFDMExec(root_dir or jsbsim_root_dir())
            self._fdm.set_debug_level(0)
            if not self._fdm.load_model("F450"):  # pragma: no cover - the model ships in the wheel
                raise RuntimeError("JSBSim could not load the F450 model")
        self._fdm.set_dt(DT)
        # Bound accessors of the property nodes read or written every control tick: ``fdm[name]`` looks the name
        # up on every call, which costs more than the physics of a step when done twenty times per tick.
        self._read = tuple(self._node(name).get_double_value for name in _STATE_PROPERTIES)
        self._write_controls = tuple(self._node(name).set_double_value for name in _CONTROL_PROPERTIES)
        self._write_gust = tuple(self._node(name).set_double_value for name in _GUST_PROPERTIES)
        r_m, r_n = earth_radii(home_lat_deg)
        self._k_north = math.radians(1.0) * r_m
        self._k_east = math.radians(1.0) * r_n * math.cos(math.radians(home_lat_deg))
        self.reset()

    def _node(self, name: str) -> jsbsim.FGPropertyNode:
        node = self._fdm.get_property_manager().get_node(name)
        if node is None:  # pragma: no cover - the names are the model's, checked by the tests
            raise RuntimeError(f"the F450 model has no property {name}")
        return node

    @property
    def fdm(self) -> jsbsim.FGFDMExec:
        """The underlying JSBSim executive (for properties this wrapper does not expose)."""
        return self._fdm

    def reset(self) -> None:
        """Put the aircraft back on the ground at home, level, motors stopped, no wind."""
        fdm = self._fdm
        fdm["ic/lat-geod-deg"] = self.home_lat_deg
        fdm["ic/long-gc-deg"] = self.home_lon_deg
        fdm["ic/terrain-elevation-ft"] = self.home_alt_msl_m / FT
        fdm["ic/h-agl-ft"] = GEAR_HEIGHT_M / FT
        fdm["ic/psi-true-deg"] = self.heading_deg
        fdm["ic/phi-deg"] = 0.0
        fdm["ic/theta-deg"] = 0.0
        fdm["ic/vt-fps"] = 0.0
        self.set_wind(0.0, 0.0, 0.0)
        self.set_gust(0.0, 0.0, 0.0)
        self.set_controls(0.0, 0.0, 0.0, 0.0)
        self.set_engaged(False)
        with _quiet_stdio():
            if not fdm.run_ic():  # pragma: no cover
                raise RuntimeError("JSBSim rejected the initial conditions")
        self._time_offset = fdm["simulation/sim-time-sec"]
        # Let the gear springs settle so the first state the caller sees is at rest.
        self.step(125)
        self._time_offset = fdm["simulation/sim-time-sec"]

    def place(self, state: ModelState, controls: tuple[float, float, float, float] | None) -> None:
        """Put the aircraft in ``state`` (position, velocity, attitude, body rates), as when resuming a snapshot.

        ``controls`` (throttle and body rates, as :meth:`set_controls`) are those of an armed vehicle, None when
        disarmed. JSBSim starts every propeller at rest, and a hovering aircraft whose propellers must first spin
        up sinks for a moment; so an armed aircraft is first held in place (``forces/hold-down``), level and still,
        for :data:`SPIN_UP_STEPS` at the snapshot's throttle, and only then released into its state
        (``run_ic`` keeps the propellers' speed). A landed aircraft is set on its gear and left to settle."""
        fdm = self._fdm

        def initial(moving: bool) -> None:
            fdm["ic/lat-geod-deg"] = state.lat_deg
            fdm["ic/long-gc-deg"] = state.lon_deg
            fdm["ic/terrain-elevation-ft"] = self.home_alt_msl_m / FT
            fdm["ic/h-agl-ft"] = (max(0.0, state.alt_agl_m) + GEAR_HEIGHT_M) / FT
            fdm["ic/psi-true-rad"] = state.yaw_rad % _TWO_PI
            fdm["ic/phi-rad"] = state.roll_rad if moving else 0.0
            fdm["ic/theta-rad"] = state.pitch_rad if moving else 0.0
            fdm["ic/vn-fps"] = state.vn_mps / FT if moving else 0.0
            fdm["ic/ve-fps"] = state.ve_mps / FT if moving else 0.0
            fdm["ic/vd-fps"] = state.vd_mps / FT if moving else 0.0
            fdm["ic/p-rad_sec"] = state.p_rps if moving else 0.0
            fdm["ic/q-rad_sec"] = state.q_rps if moving else 0.0
            fdm["ic/r-rad_sec"] = state.r_rps if moving else 0.0
            with _quiet_stdio():
                if not fdm.run_ic():  # pragma: no cover
                    raise RuntimeError("JSBSim rejected the initial conditions")

        self.set_wind(0.0, 0.0, 0.0)
        self.set_gust(0.0, 0.0, 0.0)
        self.set_engaged(controls is not None)
        if state.on_ground:
            initial(False)
            self.set_controls(*(controls or (0.0, 0.0, 0.0, 0.0)))
            self.step(125)  # the gear springs settle, as in :meth:`reset`
        else:
            initial(False)
            if controls is not None:
                self.set_controls(controls[0], 0.0, 0.0, 0.0)
                fdm["forces/hold-down"] = 1.0
                self.step(SPIN_UP_STEPS)
                fdm["forces/hold-down"] = 0.0
            initial(True)
            self.set_controls(*(controls or (0.0, 0.0, 0.0, 0.0)))
        self._time_offset = fdm["simulation/sim-time-sec"]

    def set_engaged(self, engaged: bool) -> None:
        """Engage (armed) or disengage (disarmed) the model's rate loop via ``fcs/ScasEngage``."""
        self._fdm["fcs/ScasEngage"] = 1.0 if engaged else 0.0

    def set_controls(self, throttle: float, p_rps: float, q_rps: float, r_rps: float) -> None:
        """Collective throttle ``[0, 1]`` and body-rate targets (rad/s); held until the next call."""
        set_throttle, set_roll, set_pitch, set_yaw = self._write_controls
        set_throttle(_clip(throttle, 0.0))
        set_roll(_clip(p_rps / RATE_PER_STICK, -1.0))
        set_pitch(_clip(q_rps / RATE_PER_STICK, -1.0))
        set_yaw(_clip(r_rps / RATE_PER_STICK, -1.0))

    def set_motor_failed(self, index: int, failed: bool) -> None:
        """Zero one ESC's output (``index`` 0..3 in :attr:`ModelState.motor_outputs` order) through the actuator's
        ``malfunction/fail_zero`` property, or give it back; the rate loop and mixer carry on unaware."""
        self._fdm[f"fcs/{_ESC_NAMES[index]}/malfunction/fail_zero"] = 1.0 if failed else 0.0

    def set_wind(self, north_mps: float, east_mps: float, down_mps: float) -> None:
        """Steady wind: the velocity (m/s, NED) the air moves towards."""
        fdm = self._fdm
        fdm["atmosphere/wind-north-fps"] = north_mps / FT
        fdm["atmosphere/wind-east-fps"] = east_mps / FT
        fdm["atmosphere/wind-down-fps"] = down_mps / FT

    def set_gust(self, north_mps: float, east_mps: float, down_mps: float) -> None:
        """Gust component (m/s, NED) added by JSBSim to the steady wind."""
        set_north, set_east, set_down = self._write_gust
        set_north(north_mps / FT)
        set_east(east_mps / FT)
        set_down(down_mps / FT)

    def step(self, n: int = 1) -> None:
        """Advance ``n`` steps of :data:`DT`."""
        run = self._fdm.run
        for _ in range(n):
            run()

    @property
    def time_s(self) -> float:
        """Simulated seconds since the last :meth:`reset`."""
        return float(self._fdm["simulation/sim-time-sec"]) - self._time_offset

    def state(self) -> ModelState:
        """The true state in SI units."""
        (
            get_lat,
            get_lon,
            get_h_sl_m,
            get_h_agl_ft,
            get_vn,
            get_ve,
            get_vd,
            get_phi,
            get_theta,
            get_psi,
            get_p,
            get_q,
            get_r,
            get_wow,
            get_m0,
            get_m1,
            get_m2,
            get_m3,
            get_t,
        ) = self._read
        lat, lon = get_lat(), get_lon()
        alt = get_h_sl_m() - GEAR_HEIGHT_M
        agl = get_h_agl_ft() * FT - GEAR_HEIGHT_M
        return _new_state(
            ModelState,
            (
                get_t() - self._time_offset,
                lat,
                lon,
                alt,
                agl if agl > 0.0 else 0.0,
                (lat - self.home_lat_deg) * self._k_north,
                (lon - self.home_lon_deg) * self._k_east,
                self.home_alt_msl_m - alt,
                get_vn() * FT,
                get_ve() * FT,
                get_vd() * FT,
                get_phi(),
                get_theta(),
                (get_psi() + math.pi) % _TWO_PI - math.pi,
                get_p(),
                get_q(),
                get_r(),
                get_wow() > 0.5,
                (get_m0(), get_m1(), get_m2(), get_m3()),
            ),
        )


_new_state = tuple.__new__
"""Builds a :class:`ModelState` from a tuple of all its fields without the Python-level ``__new__`` of a named
tuple (the same object, built once per control tick)."""
_TWO_PI = 2.0 * math.pi


_STATE_PROPERTIES = (
    "position/lat-geod-deg",
    "position/long-gc-deg",
    "position/h-sl-meters",
    "position/h-agl-ft",
    "velocities/v-north-fps",
    "velocities/v-east-fps",
    "velocities/v-down-fps",
    "attitude/phi-rad",
    "attitude/theta-rad",
    "attitude/psi-rad",
    "velocities/p-rad_sec",
    "velocities/q-rad_sec",
    "velocities/r-rad_sec",
    "gear/wow",
    "fcs/throttle-pos-norm[0]",
    "fcs/throttle-pos-norm[1]",
    "fcs/throttle-pos-norm[2]",
    "fcs/throttle-pos-norm[3]",
    "simulation/sim-time-sec",
)
"""Read by :meth:`F450Model.state`, in the order it unpacks them."""
_CONTROL_PROPERTIES = (
    "fcs/throttle-cmd-norm[0]",
    "fcs/aileron-cmd-norm",
    "fcs/elevator-cmd-norm",
    "fcs/rudder-cmd-norm",
)
_ESC_NAMES = ("front-right", "aft-left", "front-left", "aft-right")
"""The ESC actuators of ``Effectors.xml`` as JSBSim names their properties (``fcs/<name>/malfunction/fail_zero``),
in motor-output order; PX4's quad X numbers its motors in the same order (1 front right … 4 aft right)."""
_GUST_PROPERTIES = ("atmosphere/gust-north-fps", "atmosphere/gust-east-fps", "atmosphere/gust-down-fps")
