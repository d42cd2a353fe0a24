"""A MAVLink telemetry log (``.tlog``), the format QGroundControl and MAVProxy write and replay: every frame as it
went over the link, each after an 8-byte big-endian count of microseconds since the Unix epoch.

Why: a flight must be replayable by the tools people already have. :class:`TlogWriter` is a frame tap
(``Callable[[bytes], None]``) for the vehicle's or the client's link; it writes into a 64 KiB buffer under its own
lock, in the thread that sent or read the frame, and flushes at most once a second, so a tap costs a buffer copy.
Stamps never go back: a frame stamped earlier than the last one gets the last one's stamp.

Reopening a log appends to it; a last record cut short (a killed process) is cut off first, so the file stays
readable from its first record to its last.

>>> import tempfile
>>> from pymavlink import mavutil
>>> from pymavlink.dialects.v20 import common
>>> path = Path(tempfile.mkdtemp()) / "flight.tlog"
>>> mav = common.MAVLink(None, srcSystem=1, srcComponent=1)
>>> log = TlogWriter(path, clock=lambda: 1_700_000_000.0)
>>> log(common.MAVLink_heartbeat_message(2, 12, 0, 0, 3, 3).pack(mav))
>>> log.close()
>>> msg = mavutil.mavlink_connection(str(path)).recv_match(type="HEARTBEAT")
>>> msg.type, msg._timestamp
(2, 1700000000.0)
"""

from __future__ import annotations

import struct
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import BinaryIO

STAMP = struct.Struct(">Q")
BUFFER_BYTES = 64 * 1024
MAGIC_V1, MAGIC_V2 = 0xFE, 0xFD
SIGNED = 0x01
"""MAVLink 2's incompatibility flag for a signed frame (13 more bytes at the end)."""


def frame_length(head: bytes) -> int | None:
    """The length of the MAVLink frame starting with ``head`` (at least its first 3 bytes), None if it is none.

    >>> frame_length(bytes([0xFD, 9, 0])), frame_length(bytes([0xFD, 9, 1])), frame_length(bytes([0xFE, 9, 0]))
    (21, 34, 17)
    """
    if len(head) < 3:
        return None
    if head[0] == MAGIC_V2:
        return 12 + head[1] + (13 if head[2] & SIGNED else 0)
    if head[0] == MAGIC_V1:
        return 8 + head[1]
    return None


def complete_records(path: Path) -> tuple[int, int]:
    """(bytes of whole records from the start of the log at ``path``, the last whole record's stamp in µs)."""
    data = path.read_bytes() if path.is_file() else b""
    good, last = 0, 0
    while good + STAMP.size < len(data):
        length = frame_length(data[good + STAMP.size : good + STAMP.size + 3])
        end = good + STAMP.size + (length or 0)
        if length is None or end > len(data):
            break
        last = STAMP.unpack_from(data, good)[0]
        good = end
    return good, last


class TlogWriter:
    """Appends each frame it is given to a ``.tlog`` (see the module docstring); ``clock`` says the time now, in
    seconds since the Unix epoch. Call :meth:`close` at the end; frames after it are ignored."""

    def __init__(self, path: Path, clock: Callable[[], float] = time.time, *, flush_s: float = 1.0) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        whole, self.last_us = complete_records(path)
        """The latest stamp written (that of the last record already in the file, at first; 0 for a new log)."""
        if path.is_file() and path.stat().st_size > whole:
            with path.open("r+b") as cut:
                cut.truncate(whole)
        self.path = path
        self.clock = clock
        self.frames = 0
        self.flush_s = flush_s
        self._out: BinaryIO = path.open("ab", buffering=BUFFER_BYTES)
        self._lock = threading.Lock()
        self._flushed = time.monotonic()

    def __call__(self, frame: bytes) -> None:
        with self._lock:
            if self._out.closed:
                return
            self.last_us = stamp = max(int(self.clock() * 1e6), self.last_us)
            self._out.write(STAMP.pack(stamp) + frame)
            self.frames += 1
            now = time.monotonic()
            if now - self._flushed >= self.flush_s:
                self._flushed = now
                self._out.flush()

    def flush(self) -> None:
        with self._lock:
            if not self._out.closed:
                self._out.flush()

    def close(self) -> None:
        """Write out what is buffered and close the file (idempotent)."""
        with self._lock:
            if not self._out.closed:
                self._out.close()


def simulated_clock(sim_time: Callable[[], float], not_before_us: int = 0) -> Callable[[], float]:
    """A :class:`TlogWriter` clock for a simulated vehicle: the wall clock now plus the simulated seconds since,
    so a replay runs at the simulation's own pace whatever speed it ran at, and never before ``not_before_us``
    (the log's last stamp, when a resumed run appends to it).

    >>> clock = simulated_clock(lambda: 10.0, not_before_us=4_000_000_000_000_000)
    >>> clock()
    4000000000.0
    """
    anchor = max(time.time(), not_before_us / 1e6) - sim_time()
    return lambda: anchor + sim_time()


__all__ = ["TlogWriter", "complete_records", "frame_length", "simulated_clock"]
