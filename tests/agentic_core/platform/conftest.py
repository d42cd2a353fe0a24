"""Shared parts of the platform's end-to-end tests: the emergency mission over the near-emergency scene (the
casualty 40 m from home, so a run takes seconds of the test even at real time), an SMTP server, a model stand-in
that answers as slowly as asked, and readers of a run's trace."""

from __future__ import annotations

import json
import math
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from agentic_core.run.runner import MissionRun, RunResult
from flight.geodesy import local_offset
from flight.sim.scene_file import load_scene
from tests.waiting import wait_for

from ..reasoning.llm.standin import Reply, StandIn
from ..run.scripted_model import ScriptedModel

REPO = Path(__file__).resolve().parents[3]
EMERGENCY = REPO / "missions" / "hajj_emergency.yaml"
NEAR = REPO / "tests" / "agentic_core" / "run" / "scenes" / "near_emergency.yaml"
PARAMS = {"rounds": "1", "still_s": "4"}
"""One patrol pass; four seconds of stillness make a collapse (the scene's casualty never moves)."""


class SlowModel:
    """The scripted model answering after ``latency_s``: as slow as the paper's own (Gemma-3 1.48 s, GPT-4 4.95 s)."""

    def __init__(self, latency_s: float) -> None:
        self.latency_s = latency_s
        self.model = ScriptedModel(still_s=4.0)

    def __call__(self, path: str, body: Any) -> Reply:
        time.sleep(self.latency_s)  # the latency under test
        return self.model(path, body)


def slow_server(latency_s: float) -> tuple[StandIn, SlowModel]:
    model = SlowModel(latency_s)
    return StandIn(responder=model), model


def trace(run_dir: Path) -> list[dict[str, Any]]:
    lines = (run_dir / "trace.jsonl").read_text(encoding="utf-8").splitlines()
    out = []
    for line in lines:
        try:
            out.append(json.loads(line))
        except json.JSONDecodeError:  # a line cut by a kill
            continue
    return out


def of_kind(records: list[dict[str, Any]], kind: str) -> list[dict[str, Any]]:
    return [r for r in records if r["kind"] == kind]


def tools_ok(records: list[dict[str, Any]], name: str) -> list[dict[str, Any]]:
    """The calls of ``name`` that acted (ok, and not a replay of a recorded result)."""
    return [r for r in of_kind(records, "tool") if r.get("name") == name and r.get("status") == "ok"
            and not r.get("replayed")]  # fmt: skip


def assert_served(
    run_dir: Path, inbox: Any, *, until_kit: bool = False, alone: bool = True, scene: Path = NEAR
) -> list[dict[str, Any]]:
    """The casualty was found (a trigger acted), assessed critical, the medical team alerted once by SMTP (the
    inbox holds that one e-mail, unless the run was not ``alone`` in sending to it), and the kit released once, on
    the ground, within metres of ``scene``'s casualty."""
    records = trace(run_dir)
    assert [r for r in of_kind(records, "trigger") if r["act"]], "no trigger acted"
    verdicts = [r["assessment"]["severity"] for r in of_kind(records, "decision") if r.get("assessment")]
    assert "critical" in verdicts, verdicts
    assert len(tools_ok(records, "alerts.notify")) == 1
    assert not alone or len(inbox.inbox.envelopes) == 1
    assert len(tools_ok(records, "flight.deploy_payload")) == 1
    order = [r["name"] for r in of_kind(records, "tool") if r.get("status") == "ok"]
    assert order.index("alerts.notify") < order.index("flight.deploy_payload")
    kit = tools_ok(records, "flight.deploy_payload")[0]["sim_t"]
    at = min(telemetry(run_dir), key=lambda t: abs(t["time_s"] - kit))
    assert at["alt_m"] < 0.5, at
    assert distance_to_casualty(at, scene) < 9.0
    return records


def telemetry(run_dir: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in (run_dir / "telemetry.jsonl").read_text(encoding="utf-8").splitlines()]


def distance_to_casualty(sample: dict[str, Any], scene_file: Path = NEAR) -> float:
    """Horizontal metres from a telemetry sample's position to the casualty of ``scene_file``."""
    scene = load_scene(scene_file)
    casualty = scene.actor("P-12").position
    north, east = local_offset(scene.home.lat_deg, scene.home.lon_deg, sample["lat_deg"], sample["lon_deg"])
    return math.hypot(north - casualty.north, east - casualty.east)


def pause_and_hold(
    run: MissionRun, ready: Callable[[], bool], what: str, settle_s: float, held: list[tuple[float, float]]
) -> Callable[[], None]:
    """An operator for :func:`fly_steered`: once ``ready()``, pause the run; after ``settle_s`` of the vehicle's
    clock (the hold brakes and settles), note three more seconds of holding in ``held``; then resume."""

    def operator() -> None:
        wait_for(ready, timeout_s=240.0, what=what)
        paused = run.clock()
        run.control.pause(by="tester")
        try:
            wait_for(lambda: run.clock() >= paused + settle_s, timeout_s=120.0, what="the hold to settle")
            start = run.clock()
            wait_for(lambda: run.clock() >= start + 3.0, timeout_s=60.0, what="three more seconds of holding")
            held.append((start, run.clock()))
        finally:
            run.control.resume(by="tester")

    return operator


def fly_steered(run: MissionRun, operator: Callable[[], None]) -> RunResult:
    """Fly ``run`` while ``operator`` steers it from another thread, as a person at the console would."""
    steer = threading.Thread(target=operator, daemon=True)
    steer.start()
    result = run.execute()
    steer.join(timeout=10.0)
    return result
