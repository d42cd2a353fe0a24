"""The MAVLink vehicle: the simulator behind a UDP endpoint that speaks MAVLink 2 like PX4 SITL.

Why: the agent, MAVSDK, QGroundControl and pymavlink scripts must be able to fly the simulated F450 with their
default settings, exactly as they would fly PX4 SITL. :class:`MavlinkVehicle` binds one UDP socket, sends its
streams to the configured ground-station (127.0.0.1:14550) and API (127.0.0.1:14540) addresses and to every
address that has sent it a valid MAVLink message, and answers each request to its sender.

Time: one *vehicle tick* is ``tick_steps`` simulator steps (5 × 1/250 s = 20 ms by default). Each tick reads all
waiting datagrams, steps the simulator, advances the :class:`~flight.mavlink.navigator.Navigator` and sends the
streams that have fallen due in *simulated* time, so rates are sim-time rates whatever the speed. The caller can
drive ticks in lockstep (:meth:`MavlinkVehicle.step`, :meth:`MavlinkVehicle.run_for`) or let
:meth:`MavlinkVehicle.run` pace them against the wall clock (``speed=1.0`` real time, ``speed=None`` as fast as
possible), usually on a thread started by :meth:`MavlinkVehicle.start` and ended by :meth:`MavlinkVehicle.stop`.

Robustness: each datagram is parsed by a fresh pymavlink parser in robust mode, so a truncated or corrupt datagram
cannot leave bytes behind that spoil the next one; a datagram that yields no valid message is counted in
``stats.rx_dropped`` and ignored, and a sender is only learned as a peer after a message the guard accepted (a
datagram whose every message it refused counts in ``stats.rx_refused``).

Facts relied on (MAVLink ``common.xml`` via pymavlink's generated ``dialects/v20/common.py``; PX4 behaviour from
the PX4 user guide and MAVLink developer guide):

* Message ids: HEARTBEAT 0, SYS_STATUS 1, PING 4, PARAM_REQUEST_READ 20, PARAM_REQUEST_LIST 21, PARAM_VALUE 22,
  PARAM_SET 23, GPS_RAW_INT 24, ATTITUDE 30, LOCAL_POSITION_NED 32, GLOBAL_POSITION_INT 33, COMMAND_INT 75,
  COMMAND_LONG 76, COMMAND_ACK 77, BATTERY_STATUS 147, AUTOPILOT_VERSION 148, HOME_POSITION 242,
  WIND_COV 231, MESSAGE_INTERVAL 244, EXTENDED_SYS_STATE 245, STATUSTEXT 253.
* A PING with target system and component 0 is a request; the answer echoes ``time_usec`` and ``seq`` and targets
  the sender.
* STATUSTEXT carries 50 characters; longer texts go in chunks sharing a non-zero ``id`` with rising
  ``chunk_seq``, the last one shorter than 50 (an empty one if the text is a multiple of 50 long).
* SET_POSITION_TARGET_LOCAL_NED 84 and SET_POSITION_TARGET_GLOBAL_INT 86 (offboard; :mod:`flight.mavlink.offboard`).

Message builders live in :mod:`flight.mavlink.telemetry`, sending and the streams in :mod:`flight.mavlink.sending`,
receiving and each message's dispatch in :mod:`flight.mavlink.receiving`;
failsafes (checked every tick after the navigator) in :mod:`flight.mavlink.failsafe`. The data-link failsafe counts
seconds since the last HEARTBEAT of the *commanding ground station* (:mod:`flight.mavlink.links`): simulated
seconds in lockstep (the caller drives time and its messages), wall-clock seconds while :meth:`run` runs free, so a
client's real-time heartbeat keeps the link alive at any speed.

Links and signing: every accepted message is judged first by the :class:`~flight.mavlink.guard.LinkGuard`
(MAVLink 2 signing with PX4's semantics; refusals counted in :meth:`MavlinkVehicle.security`), then learnt in the
:class:`~flight.mavlink.links.LinkTable` (one entry per peer address, the commanding ground station never evicted).

Missions (upload, download, clear, fences, Mission mode, MISSION_CURRENT at 1 Hz, MISSION_ITEM_REACHED,
MAV_CMD_MISSION_START, MAV_CMD_DO_SET_MISSION_CURRENT) are :class:`~flight.mavlink.mission_service.MissionService`'s;
its protocol timeouts run on the link clock as well.

Failure injection (MAV_CMD_INJECT_FAILURE, guarded by ``SYS_FAILURE_EN``) is
:class:`~flight.mavlink.failures.FailureInjector`'s; with the MAVLink signal failed the vehicle reads only the
command that restores it and sends nothing but that command's ACK.

Rates are kept per link, as PX4 keeps them: SET_MESSAGE_INTERVAL changes the rates of the link it came on only.
Mission transfers are per link too (:class:`~flight.mavlink.mission_service.MissionService`).

The offboard setpoint timeout (``COM_OF_LOSS_T``) runs on the link clock too, for the same reason: clients stream
setpoints at wall-clock rates (MAVSDK at 20 Hz), which faster than real time would look like a lost stream.
"""

from __future__ import annotations

import math
import select
import socket
import threading
import time
from collections import deque
from collections.abc import Callable
from pathlib import Path

from pymavlink.dialects.v20 import common as mavlink2
from pymavlink.dialects.v20.common import (  # MAVLink's own constants, not restated here
    MAV_AUTOPILOT_PX4,
    MAV_STATE_ACTIVE,
    MAV_STATE_CRITICAL,
    MAV_STATE_STANDBY,
    MAV_TYPE_QUADROTOR,
)

from agentic_core.contracts.telemetry import TelemetrySample
from flight.mavlink import snapshot as vehicle_snapshot
from flight.mavlink.failsafe import Failsafes
from flight.mavlink.failures import FailureInjector
from flight.mavlink.guard import LinkGuard
from flight.mavlink.links import MAX_PEERS, LinkTable, StreamSchedule
from flight.mavlink.mission_service import MissionService
from flight.mavlink.navigator import Navigator
from flight.mavlink.pacing import ClockThread, Pacer, Speed
from flight.mavlink.params import ParamStore
from flight.mavlink.receiving import MSG_HEARTBEAT, Receiver, readiness
from flight.mavlink.sending import STATUSTEXT_LEN, Sender
from flight.mavlink.snapshot import VehicleSnapshot
from flight.mavlink.telemetry import (
    ATTITUDE,
    AUTOPILOT_VERSION,
    BATTERY_STATUS,
    EXTENDED_SYS_STATE,
    GLOBAL_POSITION_INT,
    GPS_RAW_INT,
    HEARTBEAT,
    HOME_POSITION,
    LOCAL_POSITION_NED,
    MISSION_CURRENT,
    SYS_STATUS,
    WIND_COV,
    Fields,
    LinkStats,
    TelemetryBuilders,
    WireCodec,
)
from flight.px4 import FlightMode
from flight.sim import Simulator, VehicleState

Address = tuple[str, int]


MSG_SYS_STATUS = 1
MSG_GPS_RAW_INT = 24
MSG_ATTITUDE = 30
MSG_LOCAL_POSITION_NED = 32
MSG_GLOBAL_POSITION_INT = 33
MSG_MISSION_CURRENT = 42
MSG_BATTERY_STATUS = 147
MSG_AUTOPILOT_VERSION = 148
MSG_WIND_COV = 231
MSG_HOME_POSITION = 242
MSG_EXTENDED_SYS_STATE = 245

DEFAULT_RATES_HZ: dict[int, float] = {
    MSG_HEARTBEAT: 1.0,
    MSG_SYS_STATUS: 1.0,
    MSG_BATTERY_STATUS: 0.5,
    MSG_ATTITUDE: 10.0,
    MSG_LOCAL_POSITION_NED: 5.0,
    MSG_GLOBAL_POSITION_INT: 5.0,
    MSG_GPS_RAW_INT: 1.0,
    MSG_EXTENDED_SYS_STATE: 1.0,
    MSG_HOME_POSITION: 0.5,
    MSG_MISSION_CURRENT: 1.0,
    MSG_WIND_COV: 1.0,
}
"""Default stream rates (Hz of simulated time): ours, of the order of PX4's defaults on a UDP link. Streams due in
the same tick go out in this order: attitude and local position before GLOBAL_POSITION_INT, which completes a
client's sample (:meth:`flight.client.streams.StreamsClient.on_sample`)."""


__all__ = [
    "DEFAULT_RATES_HZ",
    "MAV_AUTOPILOT_PX4",
    "MAV_STATE_ACTIVE",
    "MAV_STATE_CRITICAL",
    "MAV_STATE_STANDBY",
    "MAV_TYPE_QUADROTOR",
    "MAX_PEERS",
    "STATUSTEXT_LEN",
    "LinkStats",
    "MavlinkVehicle",
]


class MavlinkVehicle(TelemetryBuilders, Sender, Receiver):
    """The simulator on the network as a PX4 quadrotor. Close it (or use ``with``) to free the socket.

    Signing: ``signing_key`` (32 bytes) turns MAVLink 2 signing on; ``key_store`` is where the key lives between
    runs, PX4's way (read at start, written by SETUP_SIGNING); ``require_signing`` (default: whether there is a
    key) refuses commands while there is no key (:mod:`flight.mavlink.guard`)."""

    def __init__(
        self,
        simulator: Simulator,
        *,
        gcs: Address | None = ("127.0.0.1", 14550),
        api: Address | None = ("127.0.0.1", 14540),
        bind: Address = ("127.0.0.1", 0),
        system_id: int = 1,
        component_id: int = 1,
        params: dict[str, float] | None = None,
        tick_steps: int = 5,
        signing_key: bytes | None = None,
        key_store: str | Path | None = None,
        require_signing: bool | None = None,
    ) -> None:
        if not (1 <= system_id <= 255 and 1 <= component_id <= 255):
            raise ValueError("system and component ids are 1..255")
        if tick_steps < 1:
            raise ValueError("tick_steps must be >= 1")
        self.sim = simulator
        self.system_id = system_id
        self.component_id = component_id
        self.params = ParamStore(params)
        self.navigator = Navigator(simulator, self.params)
        self.navigator.notify = self.statustext
        self.failsafes = Failsafes(self.navigator, self.statustext)
        self.failures = FailureInjector(self.navigator, self.statustext)
        """MAV_CMD_INJECT_FAILURE (:mod:`flight.mavlink.failures`); with the MAVLink signal off the link is dead."""
        self.last_rx_s: float | None = None  # on the link clock: simulated time in lockstep, wall time in run()
        self._link_clock: Callable[[], float] = lambda: self.sim.time_s
        """Simulated time of the last valid message from any peer (None: none yet)."""
        self.navigator.clock = lambda: self._link_clock()  # offboard setpoint streams are timed like the link
        self._setpoint_warned_s = -math.inf
        self.stats = LinkStats()
        self.statustexts: deque[tuple[int, str]] = deque(maxlen=100)
        """The last STATUSTEXTs sent, as (severity, text)."""
        self.tick_steps = tick_steps
        self.on_tick: list[Callable[[VehicleState], None]] = []
        """Called after every tick with the simulator's state, in the vehicle's thread (e.g. a camera)."""
        self.on_telemetry: list[Callable[[TelemetrySample], None]] = []
        """Called after every tick with what the vehicle reports (:meth:`telemetry_sample`), in the vehicle's thread;
        the sample is only built while there is a hook."""
        self.tick_errors: deque[str] = deque(maxlen=100)
        """What the ``on_tick``, ``on_telemetry`` and ``on_wire`` hooks (and a pace) raised; the vehicle flies on."""
        self.on_wire: list[Callable[[bytes], None]] = []
        """Called with every frame the vehicle sends or takes in (e.g. a flight log), in the thread holding its lock."""
        self._mav = mavlink2.MAVLink(None, srcSystem=system_id, srcComponent=component_id)
        self._targets: list[Address] = [a for a in (gcs, api) if a is not None]
        self.links = LinkTable()
        """The peers, the commanding ground station (:mod:`flight.mavlink.links`)."""
        self.streams = StreamSchedule({m: 1.0 / hz for m, hz in DEFAULT_RATES_HZ.items()})
        """The default stream rates (a peer that sets its own gets a copy)."""
        self._in_hand: Address | None = None
        self._text_id = 0
        self._lock = threading.RLock()
        self.guard = LinkGuard(
            key=signing_key, key_store=key_store, required=require_signing, notify=lambda t, s: self.statustext(t, s)
        )
        """Signing and the armed-vehicle rules (:mod:`flight.mavlink.guard`)."""
        self.guard.signer.attach(self._mav)
        self._clock = ClockThread("mavlink-vehicle")
        self._stop = self._clock.stop_event
        self.missions = MissionService(
            self.navigator,
            self._mav,
            system_id=system_id,
            component_id=component_id,
            send=self._send,
            notify=self.statustext,
            clock=lambda: self._link_clock(),
            protected=lambda address: self.links.commander is not None and self.links.commander[0] == address,
            fence_locked=lambda: self.guard.fence_plan_locked(armed=self.sim.armed),
        )
        self._builders: dict[int, tuple[WireCodec, Callable[[], Fields]]] = {
            MSG_HEARTBEAT: (HEARTBEAT, self._heartbeat_fields),
            MSG_SYS_STATUS: (SYS_STATUS, self._sys_status_fields),
            MSG_BATTERY_STATUS: (BATTERY_STATUS, self._battery_status_fields),
            MSG_ATTITUDE: (ATTITUDE, self._attitude_fields),
            MSG_GLOBAL_POSITION_INT: (GLOBAL_POSITION_INT, self._global_position_int_fields),
            MSG_LOCAL_POSITION_NED: (LOCAL_POSITION_NED, self._local_position_ned_fields),
            MSG_GPS_RAW_INT: (GPS_RAW_INT, self._gps_raw_int_fields),
            MSG_EXTENDED_SYS_STATE: (EXTENDED_SYS_STATE, self._extended_sys_state_fields),
            MSG_HOME_POSITION: (HOME_POSITION, self._home_position_fields),
            MSG_AUTOPILOT_VERSION: (AUTOPILOT_VERSION, self._autopilot_version_fields),
            MSG_MISSION_CURRENT: (MISSION_CURRENT, self.missions.current_fields),
            MSG_WIND_COV: (WIND_COV, self._wind_cov_fields),
        }
        """Every message the vehicle can build: streams and REQUEST_MESSAGE."""
        self._destinations_cache: tuple[int, tuple[Address, ...]] | None = None
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self._sock.bind(bind)
            self._sock.setblocking(False)
        except OSError:
            self._sock.close()
            raise
        self._readable = readiness(self._sock)
        self._closed = False

    # -- lifecycle --------------------------------------------------------------------------------------------

    @property
    def address(self) -> Address:
        """The bound (host, port)."""
        host, port = self._sock.getsockname()[:2]
        return str(host), int(port)

    @property
    def mode(self) -> FlightMode:
        return self.navigator.mode

    @property
    def peers(self) -> list[Address]:
        """Addresses that have sent an accepted message, most recent last."""
        return list(self.links.peers)

    def security(self) -> dict[str, int]:
        """What the guard refused and accepted (signing verdicts, armed-vehicle rules) and the link table's
        evictions and impostors: the counters an operator (or a test) reads."""
        out = self.guard.report()
        out.update(evicted_peers=self.links.evicted, gcs_impostors=self.links.impostors)
        return out

    def close(self) -> None:
        """Stop a running pacer and close the socket (idempotent)."""
        self.stop()
        with self._lock:
            if not self._closed:
                self._closed = True
                self._sock.close()

    def __enter__(self) -> MavlinkVehicle:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- snapshots ------------------------------------------------------------------------------------------

    def snapshot(self) -> VehicleSnapshot:
        """The vehicle's state, simulator included, to resume it elsewhere (:mod:`flight.mavlink.snapshot`)."""
        with self._lock:
            return vehicle_snapshot.take(self)

    def restore(self, snap: VehicleSnapshot) -> None:
        """Put this vehicle into ``snap``'s state (a bad snapshot raises
        :class:`~flight.sim.snapshot.SnapshotError` before anything changes)."""
        with self._lock:
            vehicle_snapshot.apply(self, snap)
            self.failures.clear()  # the simulator is a fresh one: failures are not in snapshots

    # -- time -------------------------------------------------------------------------------------------------

    @property
    def tick_s(self) -> float:
        return self.tick_steps * self.sim.dt

    def step(self) -> None:
        """One vehicle tick: read datagrams, step the simulator, advance the navigator, send due streams."""
        with self._lock:
            if self._closed:
                raise RuntimeError("vehicle is closed")
            self._poll()
            self.sim.step(self.tick_steps)
            self.navigator.update()
            self.failsafes.update(self.last_rx_s, self._link_clock())
            self.failures.update()
            self.missions.tick(self.sim.time_s)
            self.guard.signer.tick()
            self._send_streams()
            if self.on_tick:
                state = self.sim.state()
                for hook in self.on_tick:
                    try:
                        hook(state)
                    except Exception as exc:  # an observer's bug must not stop the aircraft
                        self._hook_failed(hook, exc)
            if self.on_telemetry:
                sample = self.telemetry_sample()
                for listener in self.on_telemetry:
                    try:
                        listener(sample)
                    except Exception as exc:
                        self._hook_failed(listener, exc)

    def _hook_failed(self, hook: object, exc: Exception) -> None:
        self.tick_errors.append(f"{getattr(hook, '__qualname__', hook)}: {type(exc).__name__}: {exc}")

    def run_for(self, seconds: float) -> None:
        """Lockstep: ``seconds`` of simulated time, as fast as possible, in the caller's thread."""
        for _ in range(max(0, round(seconds / self.tick_s))):
            self.step()

    def run(self, speed: Speed = 1.0) -> None:
        """Tick until :meth:`stop`, at ``speed`` × real time (None: as fast as possible), answering promptly.

        ``speed`` may be a *pace* (:mod:`flight.mavlink.pacing`), asked before every tick (and while waiting for
        the next) for the speed to keep now; the wall/sim reference is re-based when its answer changes. What a
        pace raises is recorded in :attr:`tick_errors`."""
        pacer = Pacer(speed, self.tick_errors)
        self._stop.clear()
        self.link_on_wall_clock()
        current = pacer.speed
        wall0, sim0 = time.monotonic(), self.sim.time_s
        while not self._stop.is_set():
            self.step()
            if pacer.ask() != current:
                current = pacer.speed
                wall0, sim0 = time.monotonic(), self.sim.time_s
            if current is None:
                continue
            target = wall0 + (self.sim.time_s - sim0) / current
            while not self._stop.is_set() and (delay := target - time.monotonic()) > 0:
                readable, _, _ = select.select([self._sock], [], [], min(delay, 0.05))
                if readable:
                    with self._lock:
                        if not self._closed:
                            self._poll()
                if pacer.changed():
                    break  # the next tick re-bases on the new answer

    def link_on_wall_clock(self) -> None:
        """Judge link loss (and offboard streams) on the wall clock from now on, as :meth:`run` does: clients send
        heartbeats at real-time rates, so faster than real time simulated seconds would make a healthy link look
        lost. A caller that ticks this vehicle at a pace of its own (:mod:`flight.mavlink.lockstep`) calls it."""
        self._link_clock = time.monotonic
        if self.last_rx_s is not None:
            self.last_rx_s = time.monotonic()
        if self.links.commander_heard is not None:
            self.links.commander_heard = time.monotonic()
        if self.navigator.offboard_time_s is not None:
            self.navigator.offboard_time_s = time.monotonic()

    def poll(self) -> None:
        """Read the datagrams waiting now and answer them, between ticks (a no-op once closed)."""
        with self._lock:
            if not self._closed:
                self._poll()

    def fileno(self) -> int:
        """The socket's descriptor, for ``select`` over several vehicles (-1 once closed)."""
        return -1 if self._closed else self._sock.fileno()

    def start(self, speed: Speed = 1.0) -> threading.Thread:
        """Run :meth:`run` on a daemon thread (``speed``: a multiple of real time, None, or a pace)."""
        return self._clock.start(self.run, speed)

    def stop(self) -> None:
        """Stop the pacer thread started by :meth:`start` (no-op when none runs)."""
        self._clock.stop()

    def inject_failure(
        self, unit: int, failure_type: int, instance: int = 0, *, value: float = math.nan, force: bool = False
    ) -> None:
        """MAV_CMD_INJECT_FAILURE in process (e.g. to give back a link the failure has cut); ``value`` is param4
        (the battery level of a battery WRONG failure); ``force`` ignores ``SYS_FAILURE_EN``. Raises
        :class:`~flight.mavlink.navigator.CommandDenied` as the command would be refused."""
        with self._lock:
            self.failures.inject(unit, failure_type, instance, value=value, enabled=True if force else None)
