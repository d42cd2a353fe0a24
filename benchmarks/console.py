"""The operator console's two targets, measured in headless Chromium (Debian's, at /usr/bin/chromium):

* **SSE latency**: a run event from its publication on the run's event bus (its ``t``, the wall clock when the
  bus made it) to the page's handler (``Date.now()`` there, the same machine's clock), while telemetry streams at
  10 Hz and events at ``--event-hz``; through the real path: bus → :class:`~agentic_core.console.LiveFeed` →
  uvicorn → sse-starlette → the browser's EventSource. Target: under 100 ms.
* **First page load**: the bytes of every response the page needs to draw (the page, its script and style,
  Leaflet, the API's first answers; the event stream itself left out). Target: under 500 KB.

Usage: ``python benchmarks/console.py [--seconds 10] [--event-hz 10]``. Exit status 0 whether the targets are met or
not; 2 when there is no browser.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from agentic_core.agent import ControlPort, EventBus
from agentic_core.console import ConsoleServer, LiveFeed
from agentic_core.console.app import Live

CHROMIUM = "/usr/bin/chromium"
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync"]  # fmt: skip
HOME = (21.4133, 39.8933)


def publish(bus: EventBus, feed: LiveFeed, seconds: float, event_hz: float, stop: threading.Event) -> None:
    """Telemetry at 10 Hz and events at ``event_hz``, on a thread of their own as a run's would be."""
    start = time.monotonic()
    next_sample = next_event = start
    n = 0
    while not stop.is_set() and time.monotonic() - start < seconds:
        now = time.monotonic()
        if now >= next_sample:
            t = now - start
            feed.telemetry({"time_s": t, "lat_deg": HOME[0] + t * 1e-6, "lon_deg": HOME[1], "alt_m": 30.0,
                            "north_m": t * 0.1, "east_m": 0.0, "yaw_deg": 0.0, "battery_pct": 90.0})  # fmt: skip
            next_sample += 0.1
        if now >= next_event:
            n += 1
            bus.publish("log", level="info", summary=f"benchmark event {n}")
            next_event += 1.0 / event_hz
        time.sleep(max(0.0, min(next_sample, next_event) - time.monotonic()))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--event-hz", type=float, default=10.0)
    args = parser.parse_args(argv)
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        print("benchmarks/console.py: needs playwright (the dev extra)", file=sys.stderr)
        return 2
    if not Path(CHROMIUM).is_file():
        print(f"benchmarks/console.py: no browser at {CHROMIUM}", file=sys.stderr)
        return 2
    feed = LiveFeed(telemetry_hz=10.0)
    bus = EventBus(clock=lambda: None)
    bus.subscribe(lambda event: feed.event(event.model_dump(mode="json")))
    feed.static = {"run_id": "benchmark", "live": True, "mission": None}
    with (
        tempfile.TemporaryDirectory() as runs,
        ConsoleServer(Path(runs), port=0, live=Live(feed, ControlPort())) as server,
        sync_playwright() as playwright,
    ):
        browser = playwright.chromium.launch(executable_path=CHROMIUM, headless=True, args=FLAGS)
        page = browser.new_page()
        responses: list[Any] = []
        page.on("response", lambda response: responses.append(response))
        page.goto(server.url, wait_until="load")
        page.wait_for_function("() => window.consoleState && window.consoleState.runId === 'benchmark'")
        worker = threading.Thread(target=publish, args=(bus, feed, args.seconds, args.event_hz, threading.Event()))
        worker.start()
        worker.join()
        time.sleep(0.5)  # the last events' way to the page
        latencies: list[float] = page.evaluate("() => window.consoleState.latencies")
        received = page.evaluate("() => window.consoleState.received || 0")
        loaded = sum(_size(r) for r in responses if "/api/live/stream" not in r.url)
        browser.close()
    if not latencies:
        print("no event reached the page", file=sys.stderr)
        return 1
    ordered = sorted(latencies)

    def pct(p: float) -> float:
        return ordered[min(len(ordered) - 1, round(p / 100 * (len(ordered) - 1)))]

    print(f"SSE latency, publication -> browser, {len(latencies)} events at {args.event_hz:g} Hz with telemetry at "
          f"10 Hz ({received} samples reached the page) over {args.seconds:g} s:")  # fmt: skip
    print(
        f"  median {statistics.median(latencies):.1f} ms, p95 {pct(95):.1f} ms, p99 {pct(99):.1f} ms, "
        f"max {max(latencies):.1f} ms  (target < 100 ms: {'met' if pct(95) < 100 else 'NOT met'} at p95)"
    )
    print(
        f"first page load: {loaded / 1024:.1f} KB in {sum('/api/live/stream' not in r.url for r in responses)} "
        f"responses (target < 500 KB: {'met' if loaded < 500 * 1024 else 'NOT met'})"
    )
    return 0


def _size(response: Any) -> int:
    try:
        return len(response.body())
    except Exception:  # a response without a body (a redirect, a 304)
        return 0


if __name__ == "__main__":
    raise SystemExit(main())
