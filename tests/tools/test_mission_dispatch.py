"""A shipped mission run through the real executor: the built-in weather tool, stand-ins for the flight and
perception tools (those layers come later), scopes, and the audit log holding every action."""

from pathlib import Path
from typing import Any

import pytest

from agentic_core.mission import Environment, compile_mission, initial_state, load_mission
from tools import Caller, JsonlAuditLog, ToolContext, ToolExecutor, ToolRegistry, read_audit_log
from tools.builtin import BuiltinConfig
from tools.loading import build_registry

MISSIONS = Path(__file__).resolve().parents[2] / "missions"


def registry_with_stand_ins(tmp_path: Path, flown: list[tuple[str, dict[str, Any]]]) -> ToolRegistry:
    config = BuiltinConfig(outbox_dir=tmp_path / "outbox", incidents_db=tmp_path / "incidents.db")
    registry = build_registry(plugins=False, config=config)

    def stand_in(name: str, scope: str) -> None:
        @registry.tool(name=name, scopes=[scope])
        def act(context: ToolContext, lat: float = 0.0, lon: float = 0.0, alt_m: float = 0.0,
                altitude_m: float = 0.0, focus: str = "", min_confidence: float = 0.5) -> dict[str, Any]:  # fmt: skip
            flown.append((context.tool, {"lat": lat, "lon": lon, "alt_m": alt_m, "focus": focus}))
            return {"done": True}

    for name in ("flight.takeoff", "flight.fly_to", "flight.rtl"):
        stand_in(name, "flight:command")
    stand_in("perception.analyze_scene", "perception:read")
    return registry


def run(registry: ToolRegistry, caller: Caller, audit: Path) -> dict[str, Any]:
    plan = load_mission(MISSIONS / "inspect_perimeter.yaml", tools=registry)
    executor = ToolExecutor(registry, audit=JsonlAuditLog(audit), default_caller=caller)
    try:
        app = compile_mission(plan, Environment(dispatch=executor.dispatcher()))
        out: dict[str, Any] = app.invoke(initial_state(plan), {"recursion_limit": 200})
        return out
    finally:
        executor.close()


def test_the_perimeter_mission_flies_through_the_executor(tmp_path: Path) -> None:
    flown: list[tuple[str, dict[str, Any]]] = []
    registry = registry_with_stand_ins(tmp_path, flown)
    pilot = Caller(id="mission:P-789", scopes=frozenset({"flight:*", "perception:read", "weather:read"}))
    out = run(registry, pilot, tmp_path / "audit.jsonl")
    assert out["outputs"]["check_weather"]["source"] == "simulated"  # the embedded default: 4 m/s < 15 m/s
    assert [tool for tool, _ in flown][-3:] == ["flight.fly_to", "perception.analyze_scene", "flight.rtl"]
    fly_to = next(args for tool, args in flown if tool == "flight.fly_to")
    assert (fly_to["lat"], fly_to["lon"], fly_to["alt_m"]) == (21.4141, 39.8952, 40.0)  # templates filled in
    records = read_audit_log(tmp_path / "audit.jsonl")
    assert {r.tool for r in records} == {
        "weather.get_forecast",
        "flight.takeoff",
        "flight.fly_to",
        "perception.analyze_scene",
        "flight.rtl",
    }
    assert all(r.status == "ok" and r.caller == "mission:P-789" for r in records)


@pytest.mark.parametrize("missing", ["flight:*", "weather:read"])
def test_a_caller_without_the_scope_is_denied_and_the_mission_sees_it(tmp_path: Path, missing: str) -> None:
    flown: list[tuple[str, dict[str, Any]]] = []
    registry = registry_with_stand_ins(tmp_path, flown)
    scopes = {"flight:*", "perception:read", "weather:read"} - {missing}
    out = run(registry, Caller(id="guest", scopes=frozenset(scopes)), tmp_path / "audit.jsonl")
    assert "flight.fly_to" not in [tool for tool, _ in flown]  # never flew to the anomaly
    denied = [r for r in read_audit_log(tmp_path / "audit.jsonl") if r.status == "denied"]
    assert denied and all(missing.split(":")[0] in r.tool for r in denied)
    assert any("returned denied" in str(error) for error in out["errors"].values())
