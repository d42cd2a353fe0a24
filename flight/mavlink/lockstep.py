"""Several simulated vehicles on one clock: a swarm's vehicles ticked together, one tick each in turn, by one thread.

Why: N aircraft that share a sky must share a clock: each one's simulated second is everyone's, so separation,
rendezvous and a verification by another UAV mean the same at any speed and on any machine. One thread
(``swarm-clock``) ticks every vehicle once per round, then paces the round against the wall clock as
:meth:`~flight.mavlink.MavlinkVehicle.run` paces one vehicle (a fixed speed, as fast as possible, or a *pace*
asked every round); while it waits it answers every vehicle's datagrams. A vehicle closed meanwhile (a UAV killed)
drops out of the round; the others fly on.

>>> from flight.sim import Simulator
>>> from flight.mavlink import MavlinkVehicle
>>> fleet = [MavlinkVehicle(Simulator(seed=i), gcs=None, api=None, system_id=i + 1) for i in range(2)]
>>> clock = Lockstep(fleet)
>>> clock.run_for(0.2)
>>> [round(v.sim.time_s, 2) for v in fleet]
[0.2, 0.2]
>>> for v in fleet:
...     v.close()
"""

from __future__ import annotations

import select
import threading
import time
from collections.abc import Iterable

from flight.mavlink.pacing import ClockThread, Pacer, Speed
from flight.mavlink.vehicle import MavlinkVehicle


class Lockstep:
    """Ticks ``vehicles`` together (see the module docstring); :meth:`add` more before or while it runs."""

    def __init__(self, vehicles: Iterable[MavlinkVehicle] = ()) -> None:
        self._vehicles: list[MavlinkVehicle] = list(vehicles)
        self._lock = threading.Lock()
        self._clock = ClockThread("swarm-clock")
        self._stop = self._clock.stop_event
        self.errors: list[str] = []
        """What the pace raised, and the vehicles that dropped out (closed) and when."""
        self.rounds = 0
        self._time_s = 0.0

    @property
    def vehicles(self) -> list[MavlinkVehicle]:
        """The vehicles still ticked."""
        with self._lock:
            return list(self._vehicles)

    @property
    def time_s(self) -> float:
        """The shared simulated clock: the first vehicle's (every vehicle ticks the same steps); once every vehicle
        has dropped out, where it stopped."""
        fleet = self.vehicles
        if fleet:
            self._time_s = fleet[0].sim.time_s
        return self._time_s

    def add(self, vehicle: MavlinkVehicle) -> None:
        """Tick ``vehicle`` from the next round on (its clock must be the others': a fresh one is, at 0)."""
        if self._clock.thread is not None:
            vehicle.link_on_wall_clock()
        with self._lock:
            self._vehicles.append(vehicle)

    def step(self) -> None:
        """One round: every vehicle one tick, in the order added; a closed one is dropped."""
        for vehicle in self.vehicles:
            try:
                vehicle.step()
            except RuntimeError:  # closed under us: a UAV killed, or its run ended
                with self._lock:
                    if vehicle in self._vehicles:
                        self._vehicles.remove(vehicle)
                self.errors.append(f"system {vehicle.system_id} dropped out at {self.time_s:.2f} s")
        self.rounds += 1

    def run_for(self, seconds: float) -> None:
        """Lockstep in the caller's thread: ``seconds`` of simulated time, as fast as possible."""
        fleet = self.vehicles
        if not fleet:
            return
        for _ in range(max(0, round(seconds / fleet[0].tick_s))):
            self.step()

    def run(self, speed: Speed = None) -> None:
        """Tick rounds until :meth:`stop`, paced at ``speed`` (a multiple of real time, None, or a pace)."""
        pacer = Pacer(speed, self.errors)
        for vehicle in self.vehicles:
            vehicle.link_on_wall_clock()
        current = pacer.speed
        wall0, sim0 = time.monotonic(), self.time_s
        while not self._stop.is_set():
            self.step()
            if not self.vehicles:
                self._stop.wait(0.05)  # nothing to tick: idle until one is added or the clock stops
                continue
            if pacer.ask() != current:
                current = pacer.speed
                wall0, sim0 = time.monotonic(), self.time_s
            if current is None:
                continue
            target = wall0 + (self.time_s - sim0) / current
            while not self._stop.is_set() and (delay := target - time.monotonic()) > 0:
                self._answer(min(delay, 0.05))
                if pacer.changed():
                    break

    def _answer(self, wait_s: float) -> None:
        """Wait up to ``wait_s`` for a datagram to any vehicle, and answer what came."""
        fleet = [v for v in self.vehicles if v.fileno() >= 0]
        if not fleet:
            self._stop.wait(wait_s)
            return
        try:
            readable, _, _ = select.select(fleet, [], [], wait_s)
        except (OSError, ValueError):  # a socket closed between the list and the select
            return
        for vehicle in readable:
            vehicle.poll()

    def start(self, speed: Speed = None) -> threading.Thread:
        """Run :meth:`run` on the ``swarm-clock`` daemon thread."""
        return self._clock.start(self.run, speed)

    def stop(self) -> None:
        """Stop the thread started by :meth:`start` (the vehicles stay open: their owners close them)."""
        self._clock.stop()


__all__ = ["Lockstep"]
