"""The console's browser tests: headless Chromium (Debian's, at /usr/bin/chromium) driven by Playwright, and a
live run of the emergency mission over the near scene served by the console, answered from the page."""

from __future__ import annotations

import os
import shutil
import threading
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

from agentic_core.console import ConsoleOperator, ConsoleServer, watch
from agentic_core.run.runner import MissionRun, RunResult, RunSettings

from ..platform.conftest import EMERGENCY, NEAR, PARAMS

CHROMIUM = os.environ.get("AGENTIC_UAV_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync"]  # fmt: skip


@pytest.fixture(scope="module")
def browser(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Any]:
    """One headless Chromium for the module (a fresh profile: Playwright makes one per launch)."""
    sync_api = pytest.importorskip("playwright.sync_api")
    if not (Path(CHROMIUM).is_file() or shutil.which(CHROMIUM)):
        pytest.skip(f"no browser at {CHROMIUM} (make test installs Debian's chromium)")
    with sync_api.sync_playwright() as playwright:
        launched = playwright.chromium.launch(executable_path=CHROMIUM, headless=True, args=CHROMIUM_FLAGS)
        try:
            yield launched
        finally:
            launched.close()


@dataclass
class LiveRun:
    """A run flying on a thread, its console serving it."""

    run: MissionRun
    server: ConsoleServer
    thread: threading.Thread
    results: list[RunResult] = field(default_factory=list)
    errors: list[BaseException] = field(default_factory=list)

    def finish(self, timeout_s: float = 120.0) -> RunResult:
        self.thread.join(timeout_s)
        assert not self.thread.is_alive(), "the run did not end"
        assert not self.errors, self.errors
        return self.results[0]


@pytest.fixture
def live_run(tmp_path: Path) -> Iterator[LiveRun]:
    """The emergency mission over the near scene, fast-forwarded, its approvals asked of the console."""
    operator = ConsoleOperator(timeout_s=60.0)
    settings = RunSettings(mission=EMERGENCY, scene=NEAR, runs_dir=tmp_path / "runs", params=PARAMS, camera_hz=5.0,
                           approval="ask", approval_timeout_s=60.0)  # fmt: skip
    run = MissionRun(settings, operator=operator)
    operator.control = run.control
    server = ConsoleServer(settings.runs_dir, port=0, live=watch(run)).start()
    live = LiveRun(run, server, threading.Thread(target=lambda: None))

    def fly() -> None:
        try:
            live.results.append(run.execute())
        except BaseException as exc:  # reported by finish()
            live.errors.append(exc)

    live.thread = threading.Thread(target=fly, name="test-run", daemon=True)
    try:
        yield live
    finally:
        if live.thread.is_alive():
            run.control.abort("the test ended", by="test")
            live.thread.join(60.0)
        server.stop()
