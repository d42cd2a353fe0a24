"""Reading a ``.tlog`` in tests, as QGroundControl and MAVProxy would: pymavlink's own log reader."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pymavlink import mavutil


def read_tlog(path: Path) -> list[Any]:
    """Every message of a ``.tlog`` as pymavlink's log reader gives them (each with its ``_timestamp``)."""
    log = mavutil.mavlink_connection(str(path))
    out = []
    while (msg := log.recv_match()) is not None:
        out.append(msg)
    log.close()
    return out
