"""TraceWriter and TelemetryLog (agentic_core/run/trace.py): telemetry at no less than the asked rate of the
vehicle's clock and never two lines in one period; closed writers ignore late events; a resumed trace keeps
counting seq where the killed run stopped."""

from __future__ import annotations

import io
import json
import math
import random
import threading
from pathlib import Path
from typing import Any

import pytest

from agentic_core.agent import EventBus
from agentic_core.contracts import TelemetrySample
from agentic_core.run.state_files import read_jsonl
from agentic_core.run.trace import TelemetryLog, TraceWriter

from .fakes import wait_for

pytestmark = pytest.mark.timeout(60)


def sample(t: float) -> TelemetrySample:
    return TelemetrySample(time_s=t, lat_deg=21.4, lon_deg=39.9, alt_m=30.0, north_m=t, east_m=0.0, down_m=-30.0)


def period(t: float, hz: float) -> int:
    """The period the vehicle's clock ``t`` falls in; a sample a hair (a microsecond) short of a boundary counts as
    on it, as the log's own check has it, so float rounding of the clock decides nothing."""
    return math.floor(t * hz + 1e-6)


def periods(path: Path, hz: float) -> list[int]:
    return [period(r["time_s"], hz) for r in read_jsonl(path)]


RATES = [
    (10.0, 10.0),
    (4.0, 30.0),
    (10.0, 50.0),
    (25.0, 100.0),
]


def regular(tmp_path: Path, hz: float, sample_hz: float) -> tuple[list[int], list[float]]:
    """The periods of the lines written for 20 s of samples at ``sample_hz`` (a float clock, as it adds up)."""
    log = TelemetryLog(tmp_path / "telemetry.jsonl", hz=hz)
    times = [n / sample_hz for n in range(int(20 * sample_hz))]
    for t in times:
        log(sample(t))
    log.close()
    return periods(tmp_path / "telemetry.jsonl", hz), times


@pytest.mark.parametrize(("hz", "sample_hz"), [(10.0, 10.0), (4.0, 30.0), (10.0, 50.0), (25.0, 100.0)])
def test_a_line_in_every_period_of_the_vehicle_clock_that_has_samples(
    tmp_path: Path, hz: float, sample_hz: float
) -> None:
    written, times = regular(tmp_path, hz, sample_hz)
    assert set(written) == {period(t, hz) for t in times}  # at least the asked rate, wherever there were samples
    assert len(set(written)) >= 20 * hz * 0.99


@pytest.mark.parametrize(("hz", "sample_hz"), RATES)
def test_never_two_lines_in_one_period(tmp_path: Path, hz: float, sample_hz: float) -> None:
    written, _ = regular(tmp_path, hz, sample_hz)
    assert written == sorted(set(written))


def irregular(tmp_path: Path, hz: float) -> tuple[list[int], list[float]]:
    rng = random.Random(7)
    log = TelemetryLog(tmp_path / "telemetry.jsonl", hz=hz)
    t, times = 0.0, []
    for _ in range(3000):
        t += rng.choice([0.001, 0.013, 0.05, 0.099, 0.1, 0.101, 0.37, 2.5])
        times.append(t)
        log(sample(t))
    log.close()
    return periods(tmp_path / "telemetry.jsonl", hz), times


def test_irregular_samples_with_gaps_give_a_line_in_every_period_that_has_samples(tmp_path: Path) -> None:
    written, times = irregular(tmp_path, 10.0)
    assert set(written) == {period(t, 10.0) for t in times}


def test_irregular_samples_with_gaps_never_give_two_lines_in_one_period(tmp_path: Path) -> None:
    written, _ = irregular(tmp_path, 10.0)
    assert written == sorted(set(written))


def test_each_line_is_the_first_sample_of_its_period(tmp_path: Path) -> None:
    log = TelemetryLog(tmp_path / "telemetry.jsonl", hz=2.0)
    for t in (0.1, 0.2, 0.49, 0.5, 0.9, 1.0, 1.6, 1.9):
        log(sample(t))
    log.close()
    assert [r["time_s"] for r in read_jsonl(tmp_path / "telemetry.jsonl")] == [0.1, 0.5, 1.0, 1.6]


def test_samples_from_two_threads_never_give_two_lines_in_one_period(tmp_path: Path) -> None:
    log = TelemetryLog(tmp_path / "telemetry.jsonl", hz=10.0)
    log(sample(0.0))
    waiting = [0]
    real = log._lock

    class Counted:
        """The log's lock, counting who waits for it (so the test knows both samples are past the check)."""

        def __enter__(self) -> None:
            waiting[0] += 1
            real.acquire()

        def __exit__(self, *exc: object) -> None:
            real.release()

    log._lock = Counted()  # type: ignore[assignment]
    real.acquire()
    threads = [threading.Thread(target=log, args=(sample(t),)) for t in (0.11, 0.12)]
    for thread in threads:
        thread.start()
    try:
        wait_for(lambda: waiting[0] == 2 or all(not t.is_alive() for t in threads), what="both samples")
    finally:
        real.release()
    for thread in threads:
        thread.join(5)
    log.close()
    written = periods(tmp_path / "telemetry.jsonl", 10.0)
    assert written == sorted(set(written))


def test_a_closed_telemetry_log_ignores_late_samples(tmp_path: Path) -> None:
    path = tmp_path / "telemetry.jsonl"
    log = TelemetryLog(path, hz=10.0)
    log(sample(0.0))
    log.close()
    log.close()
    log(sample(5.0))
    assert log.lines == 1 and len(read_jsonl(path)) == 1


@pytest.mark.parametrize("hz", [0.0, -1.0, float("nan")])
def test_a_rate_that_is_not_positive_is_refused(tmp_path: Path, hz: float) -> None:
    with pytest.raises(ValueError, match="hz must be positive"):
        TelemetryLog(tmp_path / "t.jsonl", hz=hz)


def test_a_resumed_telemetry_log_appends(tmp_path: Path) -> None:
    path = tmp_path / "telemetry.jsonl"
    first = TelemetryLog(path, hz=10.0)
    for n in range(10):
        first(sample(n / 10))
    first.close()
    again = TelemetryLog(path, hz=10.0)
    for n in range(10, 20):
        again(sample(n / 10))
    again.close()
    assert periods(path, 10.0) == list(range(20))


def test_the_trace_writes_every_event_as_one_json_line_and_keeps_it(tmp_path: Path) -> None:
    path = tmp_path / "trace.jsonl"
    trace = TraceWriter(path)
    bus = EventBus(clock=lambda: 4.5)
    bus.subscribe(trace)
    bus.publish("tool", name="flight.hold", status="ok", summary="flight.hold ok")
    bus.publish("log", level="info", summary="line\nbreak")  # a newline inside stays inside one line
    lines = path.read_text(encoding="utf-8").splitlines()
    assert len(lines) == 2 and [json.loads(x)["seq"] for x in lines] == [1, 2]
    assert trace.records == [json.loads(x) for x in lines] and trace.of_kind("tool")[0]["sim_t"] == 4.5
    trace.close()


def test_a_closed_trace_ignores_late_events_in_its_file(tmp_path: Path) -> None:
    path = tmp_path / "trace.jsonl"
    trace = TraceWriter(path)
    bus = EventBus()
    bus.subscribe(trace)
    bus.publish("run", event="end")
    trace.close()
    trace.close()
    bus.publish("control", command="abort")  # an operator's command after the run ended
    assert [json.loads(x)["kind"] for x in path.read_text(encoding="utf-8").splitlines()] == ["run"]
    assert bus.errors == []


def test_a_trace_over_a_stream_it_does_not_own_leaves_it_open(tmp_path: Path) -> None:
    out = io.StringIO()
    trace = TraceWriter(out)
    EventBus().subscribe(trace)
    trace.close()
    assert not out.closed


def resume(path: Path, earlier_events: int, cut: str | None, later_events: int) -> list[dict[str, Any]]:
    """A run's trace of ``earlier_events``, killed (its last line cut short to ``cut``), then resumed as the runner
    resumes it (the records read back, the bus counting on from the last seq) for ``later_events`` more."""
    trace = TraceWriter(path)
    bus = EventBus()
    bus.subscribe(trace)
    for n in range(earlier_events):
        bus.publish("log", n=n)
    trace.close()
    if cut is not None:
        with path.open("a", encoding="utf-8") as killed:
            killed.write(cut)
    earlier = read_jsonl(path)
    resumed = TraceWriter(path)
    resumed.records.extend(earlier)
    bus = EventBus(first_seq=max((int(r.get("seq", 0)) for r in earlier), default=0))
    bus.subscribe(resumed)
    for n in range(later_events):
        bus.publish("log", n=n)
    resumed.close()
    assert [r["seq"] for r in resumed.records] == list(range(1, earlier_events + later_events + 1))
    return read_jsonl(path)


def test_a_resumed_trace_keeps_counting_seq(tmp_path: Path) -> None:
    records = resume(tmp_path / "trace.jsonl", 5, None, 3)
    assert [r["seq"] for r in records] == list(range(1, 9))


def test_a_resumed_trace_after_a_line_cut_short_by_the_kill_loses_no_event(tmp_path: Path) -> None:
    records = resume(tmp_path / "trace.jsonl", 5, '{"kind": "log", "seq": 6, "summary": "cut sh', 3)
    assert [r["seq"] for r in records] == list(range(1, 9))
