"""Vehicle backends: where a run's aircraft is. The agent reaches either one only through its MAVLink client (the
``flight.*`` tools) and the telemetry samples the backend hands out.

* :class:`SimBackend` — the embedded default: the JSBSim F450 behind our PX4-like MAVLink vehicle on 127.0.0.1, in
  this process. Its telemetry samples come in lockstep from the vehicle's own thread, and its speed follows the
  agent (:class:`~agentic_core.agent.pacing.Pace`). It can be snapshotted and restored, so a killed run resumes
  with the aircraft where it was. While an injected MAVLink failure has cut the link, it hands out no samples.
  Given a ``signing_key``, it takes only messages signed with it.
  It also streams to a ground station (``gcs``), PX4-style: a ground station there that talks back is answered
  and can command it.
* :class:`LinkBackend` — any vehicle at a MAVLink address (``udp://HOST:PORT``): ``agentic-uav sim`` in another
  process, or PX4 SITL. Its samples come from the agent's client as telemetry arrives, their times counted from
  the first one heard (``start_s`` there, :mod:`~agentic_core.run.run_clock`), not from the vehicle's boot; a
  resumed run re-attaches.
  Given a ``signing_key`` file, the client signs with the key in it (a bad file is an InputError naming it); a
  vehicle not signing as the key says is refused at :meth:`LinkBackend.start` (:mod:`~agentic_core.run.link_probe`).

Either one records its link in a ``.tlog`` (``tlog``, :mod:`flight.tlog`): the simulated vehicle's every frame sent
and taken in, stamped on its simulated clock; for a vehicle of its own, what the agent's client sends and hears.
"""

from __future__ import annotations

import queue
import socket
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol

from flight.client.streams import CAMERA_STREAMS
from flight.mavlink import MavlinkVehicle
from flight.mavlink.snapshot import VehicleSnapshot
from flight.signing import read_key_file
from flight.sim import Environment as SimEnvironment
from flight.sim import Simulator
from flight.sim.controller import Gains
from flight.sim.environment import Home
from flight.tlog import TlogWriter, simulated_clock
from flight.vehicle import VehicleClient

from ..agent.pacing import Pace
from ..contracts import InputError, TelemetrySample
from .link_probe import SigningMismatch, parse_link, signing_problem
from .run_clock import RunClock

SampleHook = Callable[[TelemetrySample], None]


class Backend(Protocol):
    """What a run needs of its vehicle backend."""

    kind: str
    signing_key: bytes | None
    """What the run's client signs with (None: the vehicle does not ask for signing)."""

    @property
    def address(self) -> tuple[str, int]: ...

    def on_sample(self, hook: SampleHook) -> None: ...

    def attach(self, client: VehicleClient) -> None: ...

    async def raise_rates(self, client: VehicleClient) -> None: ...

    def start(self) -> None: ...

    def snapshot(self) -> dict[str, Any] | None: ...

    def flush(self) -> None:
        """Hand the hooks what has been heard since the last sample, before the run says where the aircraft ended."""

    def link_clock(self) -> float:
        """The seconds a silent link is judged on (the agent's link failsafe)."""

    def close(self) -> None: ...


class SimBackend:
    """The in-process simulated vehicle (see the module docstring)."""

    kind = "sim"

    def __init__(
        self,
        *,
        home: Home | None,
        seed: int,
        pace: Pace,
        restore: dict[str, Any] | None = None,
        gcs: tuple[str, int] | None = None,
        tlog: Path | None = None,
        signing_key: bytes | None = None,
        system_id: int = 1,
        api: tuple[str, int] | None = None,
        gains: Gains | None = None,
    ) -> None:
        self.pace = pace
        self._clock_at = (time.monotonic(), 0.0)
        self.tlog_path = tlog
        self.tlog: TlogWriter | None = None
        self.signing_key = signing_key
        ground = resolve(gcs) if gcs else None
        self.sim = Simulator(environment=SimEnvironment(home=home) if home else None, seed=seed, gains=gains)
        self.vehicle = MavlinkVehicle(self.sim, gcs=ground, api=api, signing_key=signing_key, system_id=system_id)
        if restore is not None:
            try:
                self.vehicle.restore(VehicleSnapshot.model_validate(restore))
            except Exception:
                self.vehicle.close()
                raise
        self._hooks: list[SampleHook] = []
        self.vehicle.on_telemetry.append(self._sample)

    @property
    def address(self) -> tuple[str, int]:
        return self.vehicle.address

    def on_sample(self, hook: SampleHook) -> None:
        self._hooks.append(hook)

    def _sample(self, sample: TelemetrySample) -> None:
        if self.vehicle.failures.link_off:  # an injected link loss: the agent hears nothing, as over a real link
            return
        for hook in self._hooks:
            hook(sample)

    def attach(self, client: VehicleClient) -> None:
        """Nothing to do: the samples come from the vehicle itself, in lockstep."""

    async def raise_rates(self, client: VehicleClient) -> None:
        """Nothing to do: the samples come from the vehicle itself, every tick."""

    def start(self) -> None:
        if self.tlog_path is not None and self.tlog is None:
            self.tlog = TlogWriter(self.tlog_path)
            self.tlog.clock = simulated_clock(lambda: self.sim.time_s, self.tlog.last_us)
            self.vehicle.on_wire.append(self.tlog)
        self.vehicle.start(self.pace.speed)

    def snapshot(self) -> dict[str, Any] | None:
        """The vehicle's whole state (pose, velocity, battery, payload, clock, navigator) as JSON data."""
        snap = self.vehicle.snapshot()
        data: dict[str, Any] = snap.model_dump(mode="json")
        return data

    def flush(self) -> None:
        """Nothing: the simulator's samples are its state itself, in lockstep."""

    def link_clock(self) -> float:
        """The simulation's clock: in lockstep a process short of CPU runs the simulation slowly but never silences
        its samples, so only simulated seconds without a sample (an injected link loss) are a silent link. A closed
        vehicle (a killed UAV) keeps time on the wall clock from where it stopped."""
        now = time.monotonic()
        if self.vehicle.fileno() >= 0:
            self._clock_at = (now, self.sim.time_s)
            return self._clock_at[1]
        wall, sim = self._clock_at
        return sim + (now - wall)

    def close(self) -> None:
        self.vehicle.close()
        if self.tlog is not None:
            self.tlog.close()


class LinkBackend:
    """A vehicle reached over MAVLink (see the module docstring). The client's reader thread hands each sample to a
    queue; one thread of this backend (``link-samples``, started by :meth:`attach`, ended by :meth:`close`) feeds
    them to the hooks, so perception never holds up the link."""

    kind = "link"

    def __init__(
        self,
        url: str,
        *,
        camera_hz: float = 30.0,
        tlog: Path | None = None,
        signing_key: Path | None = None,
        start_s: float = 0.0,
    ) -> None:
        self.url = url
        self.tlog_path = tlog
        self.tlog: TlogWriter | None = None
        self.signing_key = read_key_file(signing_key) if signing_key is not None else None
        self.camera_hz = camera_hz
        self._address = parse_link(url)
        self._hooks: list[SampleHook] = []
        self._attached: VehicleClient | None = None
        self._lock = threading.Lock()
        self._queue: queue.Queue[TelemetrySample | None] = queue.Queue(maxsize=1000)
        self._worker: threading.Thread | None = None
        self._fed: TelemetrySample | None = None
        self.dropped = 0
        self.probe_first = True
        self.run_clock: RunClock | None = RunClock(start_s)
        """What puts each sample on the run's clock before the hooks see it (None: the vehicle's own, uptime)."""
        """Whether :meth:`start` asks the vehicle how it signs before anything is sent (a swarm has asked already)."""

    @property
    def address(self) -> tuple[str, int]:
        return self._address

    def on_sample(self, hook: SampleHook) -> None:
        self._hooks.append(hook)

    def attach(self, client: VehicleClient) -> None:
        """Feed this client's telemetry to the hooks (once per client)."""
        with self._lock:
            if self._attached is client:
                return
            self._attached = client
            if self.tlog is None and self.tlog_path is not None:
                self.tlog = TlogWriter(self.tlog_path)
            if self._worker is None:
                self._worker = threading.Thread(target=self._feed, name="link-samples", daemon=True)
                self._worker.start()
        client.on_sample(self._offer)
        if self.tlog is not None:
            client.on_wire(self.tlog)

    async def raise_rates(self, client: VehicleClient) -> None:
        """Ask the vehicle for the poses a camera at ``camera_hz`` needs (a vehicle may refuse: then fewer frames)."""
        await client.set_stream_rates(dict.fromkeys(CAMERA_STREAMS, self.camera_hz))

    def _offer(self, sample: TelemetrySample) -> None:
        try:
            self._queue.put_nowait(sample)
        except queue.Full:  # perception cannot keep up: the oldest poses are the ones to lose
            self.dropped += 1

    def _feed(self) -> None:
        while (sample := self._queue.get()) is not None:
            seen = self.run_clock(sample) if self.run_clock is not None else sample
            for hook in self._hooks:
                hook(seen)
            self._fed = sample

    def link_clock(self) -> float:
        """The wall clock: a real link's silence is wall seconds without a sample."""
        return time.monotonic()

    def flush(self, timeout_s: float = 2.0) -> None:
        """One last sample of all the client has heard, fed to the hooks before this returns (or ``timeout_s``): a
        vehicle's disarm arrives in a HEARTBEAT between position messages, and the run's end must not miss it."""
        client, worker = self._attached, self._worker
        last = client.telemetry.sample() if client is not None else None
        if last is None or worker is None or not worker.is_alive():
            return
        self._offer(last)
        deadline = time.monotonic() + timeout_s
        while self._fed is not last and time.monotonic() < deadline:
            time.sleep(0.005)  # the feed thread is the one that calls the hooks; a short poll is the wait

    def start(self) -> None:
        """Nothing to start (the vehicle runs on its own); but first the vehicle is asked how it signs its link,
        :class:`SigningMismatch` when not as ``--signing-key`` says (:func:`signing_problem`)."""
        if self.probe_first:
            self.probe_first = False  # once: a resumed run probes again in its own process
            why = signing_problem(self.url, self.signing_key)
            if why is not None:
                raise SigningMismatch(why)

    def snapshot(self) -> dict[str, Any] | None:
        """None: a vehicle of its own keeps its state; a resumed run re-attaches to it."""
        return None

    def close(self) -> None:
        """End the sample thread and the flight log (the agent's client is closed with the tools)."""
        worker = self._worker
        if worker is not None:
            self._queue.put(None)
            worker.join(timeout=5.0)
        if self.tlog is not None:
            self.tlog.close()


def resolve(address: tuple[str, int]) -> tuple[str, int]:
    """``address`` with its host as an IPv4 address, looked up once rather than at every datagram;
    :class:`InputError` when it cannot be.

    >>> resolve(("127.0.0.1", 14550))
    ('127.0.0.1', 14550)
    """
    try:
        found = socket.getaddrinfo(address[0], address[1], socket.AF_INET, socket.SOCK_DGRAM)
    except (OSError, UnicodeError) as exc:
        raise InputError(f"--gcs {address[0]}:{address[1]}: cannot find that host ({exc})") from None
    return str(found[0][4][0]), address[1]


__all__ = ["Backend", "LinkBackend", "SampleHook", "SimBackend", "parse_link", "resolve"]
