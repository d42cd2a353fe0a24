"""Snapshots of the MAVLink vehicle: the simulator's (:mod:`flight.sim.snapshot`) plus what the autopilot knows.

Why: a run resumed in a new process must find the vehicle as it left it, not only the airframe: the flight mode,
the take-off or return under way, the parameters that were set, the stream rates a client asked for, the
failsafes already acted on (a battery warning must not fire twice).

Kept: the mode and its progress (take-off altitude, return phase and altitude, the go-to under way, the cruise
speed), every parameter's value, the stream intervals, and the failsafe levels. Not kept: the mission service (the
uploaded plan and its progress) and the offboard setpoint stream, which belongs to the client: a vehicle
snapshotted in Mission or Offboard mode resumes in Hold, flying on to the target it was flying to and holding
there. Home is the simulator environment's (part of the simulator's snapshot).
"""

from __future__ import annotations

import json
from typing import TYPE_CHECKING, Literal

from pydantic import BaseModel, ConfigDict, Field, FiniteFloat, ValidationError

from flight.mavlink.navigator import RtlPhase
from flight.px4 import FlightMode
from flight.sim.snapshot import SimSnapshot, SnapshotError, describe

if TYPE_CHECKING:
    from flight.mavlink.vehicle import MavlinkVehicle

RESUMED_IN_HOLD = (FlightMode.MISSION, FlightMode.OFFBOARD)
"""Modes whose driver is not in the snapshot: the vehicle resumes in Hold."""


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class NavigatorSnapshot(_Frozen):
    mode: Literal["HOLD", "POSITION", "OFFBOARD", "MISSION", "RTL", "LAND", "TAKEOFF"]
    rtl_phase: Literal["climb", "return", "land"] | None = None
    cruise_speed_mps: FiniteFloat | None = Field(default=None, gt=0)
    takeoff_alt_m: FiniteFloat = 0.0
    rtl_alt_m: FiniteFloat = 0.0
    goto: tuple[FiniteFloat, FiniteFloat, FiniteFloat, FiniteFloat | None] | None = None


class FailsafeSnapshot(_Frozen):
    fence_breached: bool = False
    battery_level: int = Field(default=0, ge=0, le=2)


class VehicleSnapshot(_Frozen):
    """The vehicle's state: the simulator's snapshot and the autopilot's (see the module docstring)."""

    version: Literal[1] = 1
    sim: SimSnapshot
    navigator: NavigatorSnapshot
    failsafes: FailsafeSnapshot = Field(default_factory=FailsafeSnapshot)
    params: dict[str, FiniteFloat] = Field(default_factory=dict)
    stream_intervals_s: dict[int, FiniteFloat] = Field(default_factory=dict, description="0: stream off")

    @classmethod
    def from_json(cls, text: str | bytes, *, file: str = "snapshot") -> VehicleSnapshot:
        """Read a snapshot; :class:`~flight.sim.snapshot.SnapshotError` naming every bad field."""
        try:
            return cls.model_validate_json(text)
        except ValidationError as exc:
            raise SnapshotError(describe(exc, file)) from None


def take(vehicle: MavlinkVehicle) -> VehicleSnapshot:
    nav = vehicle.navigator
    return VehicleSnapshot(
        sim=vehicle.sim.snapshot(),
        navigator=NavigatorSnapshot(
            mode=nav.mode.name,
            rtl_phase=None if nav.rtl_phase is None else nav.rtl_phase.value,
            cruise_speed_mps=nav.cruise_speed_mps,
            takeoff_alt_m=nav._takeoff_alt_m,
            rtl_alt_m=nav._rtl_alt_m,
            goto=nav._goto,
        ),
        failsafes=FailsafeSnapshot(
            fence_breached=vehicle.failsafes.fence_breached, battery_level=vehicle.failsafes.battery_level
        ),
        params=dict(vehicle.params.values),
        stream_intervals_s=dict(vehicle.streams.intervals_s),
    )


def checked(snap: VehicleSnapshot, vehicle: MavlinkVehicle) -> VehicleSnapshot:
    """``snap`` validated again, and its parameters and streams checked against this vehicle's."""
    try:
        snap = VehicleSnapshot.model_validate(json.loads(snap.model_dump_json()))
    except ValidationError as exc:
        raise SnapshotError(describe(exc)) from None
    except (TypeError, ValueError) as exc:
        raise SnapshotError(f"snapshot: {exc}") from None
    problems = []
    for name, value in snap.params.items():
        spec = vehicle.params.specs.get(name)
        if spec is None:
            problems.append(f"snapshot: params.{name}: no such parameter")
        elif not spec.minimum <= value <= spec.maximum:
            problems.append(f"snapshot: params.{name}: {value:g} out of range {spec.minimum:g}..{spec.maximum:g}")
    for msg_id, interval in snap.stream_intervals_s.items():
        if vehicle.message_interval_us(msg_id) is None or interval < 0:
            problems.append(f"snapshot: stream_intervals_s.{msg_id}: not a stream, or a negative interval")
    if problems:
        raise SnapshotError("\n".join(problems))
    return snap


def apply(vehicle: MavlinkVehicle, snap: VehicleSnapshot) -> None:
    """Put the vehicle (its simulator included) into ``snap``'s state; ``snap`` is checked first."""
    snap = checked(snap, vehicle)
    vehicle.sim.restore(snap.sim)
    for name, value in snap.params.items():
        vehicle.params.set(name, value)
    n = snap.navigator
    nav = vehicle.navigator
    mode = FlightMode[n.mode]
    nav.mode = FlightMode.HOLD if mode in RESUMED_IN_HOLD else mode
    nav.rtl_phase = None if n.rtl_phase is None else RtlPhase(n.rtl_phase)
    nav.cruise_speed_mps = n.cruise_speed_mps
    nav._takeoff_alt_m = n.takeoff_alt_m
    nav._rtl_alt_m = n.rtl_alt_m
    nav._goto = n.goto
    nav.offboard_setpoint = None
    nav.offboard_time_s = None
    vehicle.failsafes.fence_breached = snap.failsafes.fence_breached
    vehicle.failsafes.battery_level = snap.failsafes.battery_level
    for msg_id, interval in snap.stream_intervals_s.items():
        vehicle.streams.intervals_s[msg_id] = interval
    vehicle.streams.restart(vehicle.sim.time_s)
    vehicle.missions.runner.recheck()  # the fence parameters may have changed


__all__ = ["FailsafeSnapshot", "NavigatorSnapshot", "VehicleSnapshot", "apply", "take"]
