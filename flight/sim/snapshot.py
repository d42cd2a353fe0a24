"""Snapshots of the simulator, to resume a flight in a fresh simulator (another process, a later run).

Why: a long run that stops (a crash, a pause for an operator, a re-run from a checkpoint) must be able to carry on
from where the aircraft was: in the air at the same position, velocity and attitude, with the same battery charge,
the same clock, the payload still released, the controller flying the same setpoint with its integrators warm.

:class:`SimSnapshot` is a frozen pydantic model that round-trips through JSON (``model_dump_json`` /
:meth:`SimSnapshot.from_json`); :func:`take` makes one and :func:`apply` puts a simulator into it (through
:meth:`~flight.sim.Simulator.snapshot`, :meth:`~flight.sim.Simulator.restore` and
:meth:`~flight.sim.Simulator.from_snapshot`). A bad snapshot raises :class:`SnapshotError` naming each bad field.

What is kept: the clock (in physics steps) and the control-tick phase; the airframe's position, velocity, attitude
and body rates; armed, payload released; the controller's setpoint, target, integrators and last output; the
battery's charge used, current and voltage; the environment (home, initial wind, GPS error model), the wind now,
the gust and GPS error processes and both random streams (generator state and the values drawn ahead), so a
restored simulator draws the same gusts and GPS errors the original would have. Not kept: JSBSim's own internal
states (its rate loop's integrators, the propellers' speed: see :meth:`~flight.sim.F450Model.place`), so a restored
flight is close to, not bit-identical with, the original.

>>> SimSnapshot.from_json('{"version": 1, "time_s": -1}', file="run.json")
Traceback (most recent call last):
...
flight.sim.snapshot.SnapshotError: run.json: time_s: Input should be greater than or equal to 0
run.json: phase: Field required
...
>>> SimSnapshot.model_json_schema()["properties"]["time_s"]["description"]
'simulated seconds since start (a whole number of 1/250 s steps)'
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import fields
from typing import TYPE_CHECKING, Any, Literal, Self

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, FiniteFloat, ValidationError, model_validator

from agentic_core.contracts.errors import InputError
from flight.sim.battery import BatteryConfig
from flight.sim.controller import ControlOutput, Gains, GoToPosition, HoldPosition, Land, Limits, VelocitySetpoint
from flight.sim.controller import Setpoint as ControllerSetpoint
from flight.sim.environment import Environment, GaussMarkov3, NormalStream, WindSettings
from flight.sim.jsbsim_model import DT, ModelState

if TYPE_CHECKING:
    from flight.sim.simulator import Simulator

SETPOINT_KINDS: dict[str, Callable[..., ControllerSetpoint]] = {
    "HoldPosition": HoldPosition,
    "GoToPosition": GoToPosition,
    "VelocitySetpoint": VelocitySetpoint,
    "Land": Land,
}


class SnapshotError(InputError):
    """A snapshot that cannot be restored; the message names every bad field."""


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class Airframe(_Frozen):
    """Where the aircraft is and how it moves (NED from home, geodetic, SI units)."""

    lat_deg: FiniteFloat = Field(ge=-90, le=90)
    lon_deg: FiniteFloat = Field(ge=-180, le=180)
    alt_msl_m: FiniteFloat
    alt_agl_m: FiniteFloat = Field(ge=0)
    north_m: FiniteFloat
    east_m: FiniteFloat
    down_m: FiniteFloat
    vn_mps: FiniteFloat
    ve_mps: FiniteFloat
    vd_mps: FiniteFloat
    roll_rad: FiniteFloat
    pitch_rad: FiniteFloat
    yaw_rad: FiniteFloat
    p_rps: FiniteFloat = 0.0
    q_rps: FiniteFloat = 0.0
    r_rps: FiniteFloat = 0.0
    on_ground: bool


class Setpoint(_Frozen):
    """The controller's setpoint: its kind and its fields (``GoToPosition``'s target, a velocity, …)."""

    kind: Literal["HoldPosition", "GoToPosition", "VelocitySetpoint", "Land"]
    args: dict[str, FiniteFloat | None] = Field(default_factory=dict)

    def build(self) -> ControllerSetpoint:
        try:
            return SETPOINT_KINDS[self.kind](**self.args)
        except TypeError as exc:
            raise ValueError(f"{self.kind} cannot take {sorted(self.args)}: {exc}") from None

    @model_validator(mode="after")
    def _buildable(self) -> Self:
        self.build()
        return self


class Controller(_Frozen):
    """The flight controller's memory and its last output (held by the airframe until the next control tick)."""

    setpoint: Setpoint
    target: dict[str, FiniteFloat | bool | None]
    loop: dict[str, FiniteFloat | None]
    landed: bool = False
    output: tuple[FiniteFloat, FiniteFloat, FiniteFloat, FiniteFloat] = (0.0, 0.0, 0.0, 0.0)


class BatteryState(_Frozen):
    config: BatteryConfig
    used_mah: FiniteFloat = Field(ge=0)
    current_a: FiniteFloat
    voltage_v: FiniteFloat = Field(ge=0)

    @model_validator(mode="after")
    def _within_capacity(self) -> Self:
        if self.used_mah > self.config.capacity_mah:
            raise ValueError(f"used_mah {self.used_mah:g} exceeds the capacity {self.config.capacity_mah:g} mAh")
        return self


class RandomStream(_Frozen):
    """A :class:`~flight.sim.environment.NormalStream`: its generator's state and the values drawn ahead."""

    generator: dict[str, Any]
    ahead: list[FiniteFloat] = Field(default_factory=list)

    @model_validator(mode="after")
    def _a_generator_state(self) -> Self:
        """Checked here, so that restoring never stops half-way on it."""
        kind = getattr(np.random, str(self.generator.get("bit_generator")), None)
        if not (isinstance(kind, type) and issubclass(kind, np.random.BitGenerator)):
            raise ValueError(f"unknown bit generator {self.generator.get('bit_generator')!r}")
        try:
            kind().state = self.generator
        except (TypeError, ValueError, KeyError) as exc:
            raise ValueError(f"not a {kind.__name__} state: {exc}") from None
        return self


class Weather(_Frozen):
    """The wind now, the gust process's value, and the GPS error processes (bias, last errors, next epoch)."""

    wind: WindSettings
    gust: tuple[FiniteFloat, FiniteFloat, FiniteFloat] | None = None
    gps_bias: tuple[FiniteFloat, FiniteFloat, FiniteFloat]
    gps_position_error: tuple[FiniteFloat, FiniteFloat, FiniteFloat]
    gps_velocity_error: tuple[FiniteFloat, FiniteFloat, FiniteFloat]
    gps_countdown_s: FiniteFloat
    gust_stream: RandomStream
    gps_stream: RandomStream


class SimSnapshot(_Frozen):
    """Everything a fresh :class:`~flight.sim.Simulator` needs to carry on a flight (see the module docstring)."""

    version: Literal[1] = 1
    time_s: FiniteFloat = Field(ge=0, description="simulated seconds since start (a whole number of 1/250 s steps)")
    phase: int = Field(ge=0, description="steps since the last control tick")
    controller_rate_hz: int = Field(gt=0)
    seed: int
    environment: Environment
    gains: Gains
    limits: Limits
    airframe: Airframe
    armed: bool
    payload_released: bool
    controller: Controller
    battery: BatteryState
    weather: Weather

    @property
    def steps(self) -> int:
        return round(self.time_s / DT)

    @model_validator(mode="after")
    def _consistent(self) -> Self:
        if abs(self.steps * DT - self.time_s) > 1e-6:
            raise ValueError(f"time_s {self.time_s!r} is not a whole number of {DT:g} s steps")
        if 250 % self.controller_rate_hz or self.phase >= 250 // self.controller_rate_hz:
            raise ValueError(f"phase {self.phase} does not fit a {self.controller_rate_hz} Hz controller")
        return self

    @classmethod
    def from_json(cls, text: str | bytes, *, file: str = "snapshot") -> SimSnapshot:
        """Read a snapshot; :class:`SnapshotError` naming every bad field (``file: a.b: message``)."""
        try:
            return cls.model_validate_json(text)
        except ValidationError as exc:
            raise SnapshotError(describe(exc, file)) from None


def describe(exc: ValidationError, file: str = "snapshot") -> str:
    """One line per problem: ``file: field.path: message``."""
    lines = []
    for err in exc.errors():
        where = ".".join(str(p) for p in err["loc"]) or "(top level)"
        lines.append(f"{file}: {where}: {err['msg']}")
    return "\n".join(lines)


def checked(snap: SimSnapshot) -> SimSnapshot:
    """``snap`` validated again (it may have been built with ``model_construct`` or ``model_copy(update=...)``)."""
    try:
        return SimSnapshot.model_validate(json.loads(snap.model_dump_json()))
    except ValidationError as exc:
        raise SnapshotError(describe(exc)) from None
    except (TypeError, ValueError) as exc:  # not even serialisable: NaN in a field built without validation, …
        raise SnapshotError(f"snapshot: {exc}") from None


def _stream(stream: NormalStream) -> RandomStream:
    rng: np.random.Generator = stream._rng
    return RandomStream(generator=rng.bit_generator.state, ahead=stream._buffer[stream._next :])


def _set_stream(stream: NormalStream, saved: RandomStream) -> None:
    try:
        stream._rng.bit_generator.state = saved.generator
    except (TypeError, ValueError, KeyError) as exc:
        raise SnapshotError(f"snapshot: weather random stream: {exc}") from None
    stream._buffer = list(saved.ahead)
    stream._next = 0


def _triple(values: list[float] | tuple[float, float, float]) -> tuple[float, float, float]:
    a, b, c = values
    return float(a), float(b), float(c)


def take(sim: Simulator) -> SimSnapshot:
    """The simulator's state now (see :meth:`flight.sim.Simulator.snapshot`)."""
    t = sim.truth()
    memory = sim.controller.memory()
    sp = memory["setpoint"]
    gust_process = sim._gusts._process
    b = sim.battery
    return SimSnapshot(
        time_s=sim.time_s,
        phase=sim._phase,
        controller_rate_hz=round(1.0 / sim._tick_dt),
        seed=sim.seed,
        environment=sim.environment,
        gains=sim.controller.gains,
        limits=sim.controller.limits,
        airframe=Airframe(**{name: getattr(t, name) for name in Airframe.model_fields}),
        armed=sim.armed,
        payload_released=sim.payload_released,
        controller=Controller(
            setpoint=Setpoint(kind=type(sp).__name__, args={f.name: getattr(sp, f.name) for f in fields(sp)}),
            target=memory["target"],
            loop=memory["loop"],
            landed=memory["landed"],
            output=tuple(sim._output),
        ),
        battery=BatteryState(config=b.config, used_mah=b.used_mah, current_a=b.current_a, voltage_v=b.voltage_v),
        weather=Weather(
            wind=sim.wind,
            gust=None if gust_process is None else _triple(gust_process.value),
            gps_bias=_triple(sim.gps._bias.value),
            gps_position_error=sim.gps.position_error,
            gps_velocity_error=sim.gps.velocity_error,
            gps_countdown_s=sim._gps_countdown,
            gust_stream=_stream(sim._gust_normals),
            gps_stream=_stream(sim.gps._rng),  # type: ignore[arg-type]
        ),
    )


def apply(sim: Simulator, snap: SimSnapshot) -> None:
    """Put ``sim``, freshly built with the snapshot's settings, into the snapshot's state."""
    a, c, w = snap.airframe, snap.controller, snap.weather
    sim._steps = snap.steps
    sim._phase = snap.phase
    sim._gps_countdown = w.gps_countdown_s
    sim._armed = snap.armed
    sim._payload_released = snap.payload_released
    sim._output = ControlOutput(*c.output)
    sim.controller.recall(c.setpoint.build(), dict(c.target), dict(c.loop), c.landed)
    battery, saved = sim.battery, snap.battery
    battery.used_mah, battery.current_a, battery.voltage_v = saved.used_mah, saved.current_a, saved.voltage_v
    sim.set_wind(w.wind)  # a new gust process draws its first value: before the streams are restored
    process = sim._gusts._process
    if isinstance(process, GaussMarkov3) and w.gust is not None:
        process.value = list(w.gust)
    _set_stream(sim._gust_normals, w.gust_stream)
    gps_stream = sim.gps._rng
    if isinstance(gps_stream, NormalStream):
        _set_stream(gps_stream, w.gps_stream)
    sim.gps._bias.value = list(w.gps_bias)
    sim.gps.position_error, sim.gps.velocity_error = w.gps_position_error, w.gps_velocity_error
    state = ModelState(time_s=0.0, motor_outputs=(0.0, 0.0, 0.0, 0.0), **a.model_dump())
    sim.model.place(state, tuple(c.output) if snap.armed else None)  # type: ignore[arg-type]
    sim.model.set_wind(w.wind.north_mps, w.wind.east_mps, w.wind.down_mps)
    if w.gust is not None and process is not None:
        sim.model.set_gust(*w.gust)
    sim._truth = sim.model.state()
    sim._truth_steps = sim._steps
    sim._version += 1
    sim._state_cache = None


def settings(snap: SimSnapshot) -> dict[str, Any]:
    """The :class:`~flight.sim.Simulator` constructor's arguments for a simulator like the snapshot's."""
    return {
        "environment": snap.environment,
        "battery": snap.battery.config,
        "gains": snap.gains,
        "limits": snap.limits,
        "seed": snap.seed,
        "controller_rate_hz": snap.controller_rate_hz,
    }


__all__ = ["SimSnapshot", "SnapshotError", "apply", "checked", "settings", "take"]
