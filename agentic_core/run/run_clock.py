"""A connected vehicle's samples on the run's clock: a vehicle of its own stamps them with its uptime (seconds since
it booted), so a run on a vehicle up half an hour would start its trace at 2,000 s and say it flew that long. The
run counts instead from the first sample it heard, on the vehicle's clock — from 0 for a new run, from where the
run stood for a resumed one — so trace, telemetry, report and summary agree, and a vehicle clock that goes back
(a reboot) never takes the run's back.

>>> from agentic_core.contracts import TelemetrySample
>>> clock = RunClock()
>>> at = lambda t: TelemetrySample(time_s=t, lat_deg=21.4, lon_deg=39.9, alt_m=0, north_m=0, east_m=0, down_m=0)
>>> [clock(at(t)).time_s for t in (2052.5, 2053.0, 2060.0, 3.0, 4.5)]
[0.0, 0.5, 7.5, 7.5, 9.0]
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from ..contracts import TelemetrySample

TAIL_BYTES = 64 * 1024
"""How much of the end of ``telemetry.jsonl`` and ``trace.jsonl`` a resumed run reads for where its time stood."""


class RunClock:
    """Each sample with ``time_s`` moved onto the run's clock (see the module docstring); call it in one thread."""

    def __init__(self, start_s: float = 0.0) -> None:
        self.start_s = start_s
        self._anchor: tuple[float, float] | None = None
        """(the vehicle's time, the run's time) at the first sample, or at the last time the vehicle's went back."""
        self._last: tuple[float, float] | None = None

    def __call__(self, sample: TelemetrySample) -> TelemetrySample:
        vehicle_t = sample.time_s
        if self._anchor is None:
            self._anchor = (vehicle_t, self.start_s)
        elif self._last is not None and vehicle_t < self._last[0]:  # the vehicle's clock went back: it rebooted
            self._anchor = (vehicle_t, self._last[1])
        run_t = self._anchor[1] + (vehicle_t - self._anchor[0])
        self._last = (vehicle_t, run_t)
        return sample.model_copy(update={"time_s": run_t})


def resumed_at(run_dir: Path, snapshot_s: float | None) -> float:
    """Where a resumed run's time stood: the latest of its snapshot's time, its last telemetry line's and its last
    trace record's (both may come after the last snapshot; the trace's end record is stamped when the run ended,
    between telemetry lines), so its telemetry and trace go on from there and never back."""
    latest = snapshot_s if snapshot_s is not None and math.isfinite(snapshot_s) else 0.0
    for name, key in (("telemetry.jsonl", "time_s"), ("trace.jsonl", "sim_t")):
        latest = max(latest, _last_time(run_dir / name, key))
    return latest


def _last_time(path: Path, key: str) -> float:
    """The largest finite ``key`` among the JSON lines at the end of ``path`` (0 when there are none)."""
    try:
        with path.open("rb") as f:
            f.seek(max(0, path.stat().st_size - TAIL_BYTES))
            tail = f.read(TAIL_BYTES)
    except OSError:
        return 0.0
    latest = 0.0
    for line in tail.splitlines()[1:] if len(tail) == TAIL_BYTES else tail.splitlines():  # a cut first line: skip
        try:
            t = json.loads(line).get(key)
        except (ValueError, AttributeError):
            continue  # a line cut short by a kill, or not a record
        if isinstance(t, int | float) and math.isfinite(t):
            latest = max(latest, float(t))
    return latest


__all__ = ["RunClock", "resumed_at"]
