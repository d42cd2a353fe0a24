"""What the client knows of the vehicle: the telemetry it folds from the vehicle's messages, and snapshots of it.

Why: every action's result carries the state observed at its end, tools report it, and waits are predicates over
it. :class:`TelemetryStore` is the mutable state the reader thread keeps (under the client's lock);
:class:`Telemetry` is the frozen snapshot handed out; :class:`TelemetrySubscription` streams snapshots as they
change.

Facts relied on (MAVLink ``common.xml`` through pymavlink's ``dialects/v20/common.py``; PX4 user guide):

* PX4 ``custom_mode`` = ``main << 16 | sub << 24``; AUTO 4 with sub LOITER 3 is "Hold", TAKEOFF 2, MISSION 4, RTL 5,
  LAND 6; POSCTL 3 with sub 1 is Orbit. Only PX4's encoding is decoded (an ArduPilot vehicle's modes would show as
  ``custom:<n>``).
* EXTENDED_SYS_STATE.landed_state: UNDEFINED 0, ON_GROUND 1, IN_AIR 2, TAKEOFF 3, LANDING 4.
* HOME_POSITION 242 carries home (degE7, mm above mean sea level).
* STATUSTEXT: 50 characters; longer texts arrive in chunks sharing a non-zero ``id``, the last one shorter.
* MISSION_CURRENT: ``seq``, ``total`` (UINT16_MAX: no mission), ``mission_state`` (MISSION_STATE: UNKNOWN 0,
  NO_MISSION 1, NOT_STARTED 2, ACTIVE 3, PAUSED 4, COMPLETE 5); MISSION_ITEM_REACHED: ``seq``.
* GPS_RAW_INT: ``fix_type`` (GPS_FIX_TYPE: 0 no GPS, 1 no fix, 2 2D, 3 3D, then DGPS and RTK), ``satellites_visible``
  (255: unknown). WIND_COV: ``wind_x``/``wind_y`` the wind estimate in m/s, north and east (NaN: none).
* Integer parameters come bytewise in PARAM_VALUE floats; their types are remembered for PARAM_SET.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import time
from collections import deque
from collections.abc import Callable
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field
from pymavlink.dialects.v20.common import (  # MAVLink's own constants, not restated here
    MAV_AUTOPILOT_PX4,
    MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
    MAV_MODE_FLAG_SAFETY_ARMED,
)

from agentic_core.contracts.telemetry import TelemetrySample
from flight.px4 import decode_custom_mode, mavlink_text

LandedState = Literal["unknown", "on_ground", "in_air", "takeoff", "landing"]
MissionState = Literal["unknown", "no_mission", "not_started", "active", "paused", "complete"]

PX4_MODES: dict[tuple[int, int], str] = {
    (1, 0): "manual",
    (2, 0): "altitude",
    (3, 0): "position",
    (3, 1): "orbit",
    (4, 1): "ready",
    (4, 2): "takeoff",
    (4, 3): "hold",
    (4, 4): "mission",
    (4, 5): "rtl",
    (4, 6): "land",
    (4, 8): "follow_target",
    (4, 9): "precland",
    (5, 0): "acro",
    (6, 0): "offboard",
    (7, 0): "stabilized",
}
LANDED_STATES: dict[int, LandedState] = {1: "on_ground", 2: "in_air", 3: "takeoff", 4: "landing"}
MISSION_STATES: dict[int, MissionState] = {
    1: "no_mission",
    2: "not_started",
    3: "active",
    4: "paused",
    5: "complete",
}

LINK_TIMEOUT_S = 3.0
"""No message from the vehicle for this long: ``Telemetry.connected`` is false."""
STATUSTEXT_LEN = 50
UINT16_MAX = 0xFFFF
UINT8_MAX = 0xFF
MAX_OPEN_CHUNKED_TEXTS = 16
LOST_CHUNK = "[…]"
"""Where a chunk of a long STATUSTEXT was lost (MAVLink 2 sends a text of more than 50 bytes in numbered chunks)."""


class Heard(BaseModel):
    """The vehicle's state as its messages report it: kept by the reader thread, snapshot in :class:`Telemetry`."""

    time_boot_s: float | None = Field(default=None, description="the vehicle's clock (simulated time in a sim)")
    lat_deg: float | None = None
    lon_deg: float | None = None
    alt_msl_m: float | None = None
    alt_m: float | None = Field(default=None, description="altitude above home")
    north_m: float | None = Field(default=None, description="LOCAL_POSITION_NED, from the local origin")
    east_m: float | None = None
    down_m: float | None = None
    vn_mps: float | None = None
    ve_mps: float | None = None
    vd_mps: float | None = None
    heading_deg: float | None = None
    roll_deg: float | None = Field(default=None, description="ATTITUDE")
    pitch_deg: float | None = Field(default=None, description="ATTITUDE")
    battery_pct: float | None = None
    battery_voltage_v: float | None = None
    armed: bool = False
    mode: str = "unknown"
    landed_state: LandedState = "unknown"
    mission_seq: int | None = Field(default=None, description="MISSION_CURRENT: the current mission item")
    mission_total: int | None = Field(default=None, description="items in the vehicle's mission (0: none)")
    mission_state: MissionState = "unknown"
    mission_reached: int | None = Field(default=None, description="the last MISSION_ITEM_REACHED")
    gps_fix_type: int | None = Field(default=None, description="GPS_RAW_INT fix_type")
    gps_satellites: int | None = Field(default=None, description="GPS_RAW_INT satellites_visible (None: unknown)")
    wind_north_mps: float | None = Field(default=None, description="WIND_COV wind_x")
    wind_east_mps: float | None = Field(default=None, description="WIND_COV wind_y")


class Telemetry(Heard):
    """What the client last heard from the vehicle. ``None`` where nothing has been heard yet."""

    model_config = ConfigDict(frozen=True)

    connected: bool = Field(description="a message arrived within the last few seconds")
    home_lat_deg: float | None = None
    home_lon_deg: float | None = None
    home_alt_msl_m: float | None = None
    last_text: str | None = Field(default=None, description="the last STATUSTEXT")

    @property
    def groundspeed_mps(self) -> float | None:
        if self.vn_mps is None or self.ve_mps is None:
            return None
        return math.hypot(self.vn_mps, self.ve_mps)

    def sample(self) -> TelemetrySample | None:
        """This telemetry as a :class:`TelemetrySample` (None until a position has been heard).

        >>> Telemetry(connected=True).sample() is None
        True
        >>> t = Telemetry(connected=True, time_boot_s=2.0, lat_deg=21.4, lon_deg=39.9, alt_m=10.0, north_m=1.0,
        ...               east_m=2.0, down_m=-10.0, mode="hold", armed=True)
        >>> t.sample().alt_m, t.sample().mode
        (10.0, 'hold')
        """
        return sample_of(self)


def sample_of(h: Heard) -> TelemetrySample | None:
    """A :class:`TelemetrySample` of what has been heard; None until GLOBAL_POSITION_INT and LOCAL_POSITION_NED
    have both arrived. Fields not heard yet (attitude, battery) take the sample's defaults."""
    lat, lon, alt, north, east, down = h.lat_deg, h.lon_deg, h.alt_m, h.north_m, h.east_m, h.down_m
    if lat is None or lon is None or alt is None or north is None or east is None or down is None:
        return None
    return TelemetrySample.model_construct(
        time_s=h.time_boot_s if h.time_boot_s is not None else 0.0,
        lat_deg=lat,
        lon_deg=lon,
        alt_m=alt,
        alt_msl_m=h.alt_msl_m,
        north_m=north,
        east_m=east,
        down_m=down,
        vn_mps=h.vn_mps or 0.0,
        ve_mps=h.ve_mps or 0.0,
        vd_mps=h.vd_mps or 0.0,
        roll_deg=h.roll_deg or 0.0,
        pitch_deg=h.pitch_deg or 0.0,
        yaw_deg=h.heading_deg or 0.0,
        battery_pct=h.battery_pct,
        mode=h.mode,
        armed=h.armed,
        landed_state=h.landed_state,
        gps_fix_type=h.gps_fix_type,
        gps_satellites=h.gps_satellites,
        wind_north_mps=h.wind_north_mps,
        wind_east_mps=h.wind_east_mps,
    )


class TelemetryState(Heard):
    """The mutable telemetry the reader thread keeps (under the client's lock)."""

    model_config = ConfigDict(arbitrary_types_allowed=True)

    last_rx: float = -math.inf
    home: tuple[float, float, float] | None = None
    texts: deque[tuple[int, str]] = Field(default_factory=lambda: deque(maxlen=50))
    """(serial number, text) of the last STATUSTEXTs."""
    text_count: int = 0


class TelemetryStore:
    """Folds the vehicle's messages into a :class:`TelemetryState` (call under the client's lock)."""

    def __init__(self) -> None:
        self.state = TelemetryState()
        self.param_types: dict[str, int] = {}
        """The MAV_PARAM_TYPE of each parameter the vehicle has reported."""
        self._chunks: dict[tuple[int, int, int], dict[int, str]] = {}

    def fold(self, msg: Any, own_component: bool) -> bool:
        """Fold ``msg`` into the state; True if the telemetry changed. ``own_component``: sent by the autopilot
        component itself (other components' heartbeats do not carry its mode)."""
        s = self.state
        s.last_rx = time.monotonic()
        kind = msg.get_type()
        if kind == "HEARTBEAT" and own_component:
            s.armed = bool(msg.base_mode & MAV_MODE_FLAG_SAFETY_ARMED)
            if msg.autopilot == MAV_AUTOPILOT_PX4 and msg.base_mode & MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
                main, sub = decode_custom_mode(msg.custom_mode)
                s.mode = PX4_MODES.get((main, sub), f"px4:{main}/{sub}")
            else:
                s.mode = f"custom:{msg.custom_mode}"
        elif kind == "GLOBAL_POSITION_INT":
            s.time_boot_s = msg.time_boot_ms / 1000.0
            s.lat_deg, s.lon_deg = msg.lat / 1e7, msg.lon / 1e7
            s.alt_msl_m, s.alt_m = msg.alt / 1000.0, msg.relative_alt / 1000.0
            s.vn_mps, s.ve_mps, s.vd_mps = msg.vx / 100.0, msg.vy / 100.0, msg.vz / 100.0
            s.heading_deg = None if msg.hdg == UINT16_MAX else msg.hdg / 100.0
        elif kind == "ATTITUDE":
            s.roll_deg, s.pitch_deg = math.degrees(msg.roll), math.degrees(msg.pitch)
            if s.heading_deg is None:  # GLOBAL_POSITION_INT's heading when it has one, else the attitude's yaw
                s.heading_deg = math.degrees(msg.yaw) % 360.0
        elif kind == "LOCAL_POSITION_NED":
            s.north_m, s.east_m, s.down_m = float(msg.x), float(msg.y), float(msg.z)
        elif kind == "SYS_STATUS":
            s.battery_pct = None if msg.battery_remaining < 0 else float(msg.battery_remaining)
            s.battery_voltage_v = None if msg.voltage_battery == UINT16_MAX else msg.voltage_battery / 1000.0
        elif kind == "EXTENDED_SYS_STATE":
            s.landed_state = LANDED_STATES.get(msg.landed_state, "unknown")
        elif kind == "GPS_RAW_INT":
            s.gps_fix_type = int(msg.fix_type)
            s.gps_satellites = None if msg.satellites_visible == UINT8_MAX else int(msg.satellites_visible)
        elif kind == "WIND_COV":
            if math.isfinite(msg.wind_x) and math.isfinite(msg.wind_y):
                s.wind_north_mps, s.wind_east_mps = float(msg.wind_x), float(msg.wind_y)
        elif kind == "HOME_POSITION":
            s.home = (msg.latitude / 1e7, msg.longitude / 1e7, msg.altitude / 1000.0)
        elif kind == "MISSION_CURRENT":
            before = (s.mission_seq, s.mission_total, s.mission_state)
            s.mission_seq = int(msg.seq)
            s.mission_total = 0 if msg.total == UINT16_MAX else int(msg.total)
            s.mission_state = MISSION_STATES.get(int(getattr(msg, "mission_state", 0)), "unknown")
            return (s.mission_seq, s.mission_total, s.mission_state) != before
        elif kind == "MISSION_ITEM_REACHED":
            s.mission_reached = int(msg.seq)
        elif kind == "STATUSTEXT":
            self._statustext(msg)
        elif kind == "PARAM_VALUE":
            self.param_types[mavlink_text(msg.param_id)] = int(msg.param_type)
            return False
        else:
            return False
        return True

    def _statustext(self, msg: Any) -> None:
        text = mavlink_text(msg.text)
        chunk_id = getattr(msg, "id", 0)
        if chunk_id:
            key = (msg.get_srcSystem(), msg.get_srcComponent(), chunk_id)
            parts = self._chunks.setdefault(key, {})
            parts[int(getattr(msg, "chunk_seq", len(parts)))] = text
            if len(text.encode()) >= STATUSTEXT_LEN:
                if len(self._chunks) > MAX_OPEN_CHUNKED_TEXTS:  # never-finished texts must not pile up
                    del self._chunks[next(iter(self._chunks))]
                return
            parts = self._chunks.pop(key)
            text = "".join(parts.get(seq, LOST_CHUNK) for seq in range(max(parts) + 1))
        self.state.text_count += 1
        self.state.texts.append((self.state.text_count, text))

    def snapshot(self, link_up: bool) -> Telemetry:
        """A frozen copy of the state; ``link_up`` false makes it disconnected whatever the last message time."""
        s = self.state
        home = s.home
        return Telemetry(
            **{name: getattr(s, name) for name in Heard.model_fields},
            connected=link_up and time.monotonic() - s.last_rx < LINK_TIMEOUT_S,
            home_lat_deg=home[0] if home else None,
            home_lon_deg=home[1] if home else None,
            home_alt_msl_m=home[2] if home else None,
            last_text=s.texts[-1][1] if s.texts else None,
        )

    def texts_since(self, mark: int) -> list[str]:
        """STATUSTEXTs received after ``mark`` (a value of ``state.text_count``)."""
        return [text for n, text in self.state.texts if n > mark]


class TelemetrySubscription:
    """An async iterator of :class:`Telemetry` snapshots, one per change (coalesced: a slow reader gets the latest,
    never a backlog). Use it on the loop that created it; close it (or leave its ``async with``) when done."""

    def __init__(self, snapshot: Callable[[], Telemetry], unsubscribe: Callable[[TelemetrySubscription], None]):
        self._snapshot = snapshot
        self._unsubscribe = unsubscribe
        self._loop = asyncio.get_running_loop()
        self._event = asyncio.Event()
        self._pending = False
        self.closed = False

    def notify(self) -> None:
        """Called by the reader thread (under the client's lock) when the telemetry changed."""
        if not self._pending and not self.closed:
            self._pending = True
            with contextlib.suppress(RuntimeError):  # the loop has closed
                self._loop.call_soon_threadsafe(self._event.set)

    def __aiter__(self) -> TelemetrySubscription:
        return self

    async def __anext__(self) -> Telemetry:
        if self.closed:
            raise StopAsyncIteration
        await self._event.wait()
        self._event.clear()
        self._pending = False
        if self.closed:
            raise StopAsyncIteration
        return self._snapshot()

    def close(self) -> None:
        self.closed = True
        self._unsubscribe(self)
        self._event.set()

    def end(self) -> None:
        """The client closed: wake the reader so its iteration stops."""
        self.closed = True
        with contextlib.suppress(RuntimeError):
            self._loop.call_soon_threadsafe(self._event.set)

    async def __aenter__(self) -> TelemetrySubscription:
        return self

    async def __aexit__(self, *exc: object) -> None:
        self.close()
