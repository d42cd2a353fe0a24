"""incidents.log and incidents.query on SQLite: filters, order, the reporter, and concurrent writers."""

from __future__ import annotations

import math
import sqlite3
import threading
from collections.abc import Callable
from datetime import UTC, datetime, timedelta

import pytest

from agentic_core.contracts.geodesy import WGS84_A, distance_m
from tools import Caller
from tools.builtin import BuiltinConfig

from .conftest import Harness

JAMARAT = (21.4225, 39.8733)


def test_log_then_query_newest_first_with_reporter(
    config: BuiltinConfig, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    tools = harness(config)
    drone = Caller(id="drone-7", scopes=frozenset({"incidents:write"}))
    ids = []
    for kind, severity in [("crowd_density", "low"), ("collapse", "critical"), ("fire", "high")]:
        result = tools.call(
            "incidents.log",
            {"kind": kind, "severity": severity, "description": f"{kind} seen", "lat": JAMARAT[0], "lon": JAMARAT[1]},
            caller=drone,
        )
        assert result.ok, result.error
        assert datetime.fromisoformat(result.output["time"]).tzinfo is not None
        ids.append(result.output["id"])
    assert ids == sorted(ids) and len(set(ids)) == 3
    found = tools.call("incidents.query", {})
    assert found.ok and found.untrusted  # descriptions are other agents' words
    assert [i["kind"] for i in found.output["incidents"]] == ["fire", "collapse", "crowd_density"]
    assert {i["reported_by"] for i in found.output["incidents"]} == {"drone-7"}
    assert found.output["count"] == 3
    assert config.incidents_db.exists()


def test_query_filters(config: BuiltinConfig, harness: Callable[[BuiltinConfig], Harness]) -> None:
    tools = harness(config)
    rows = [
        ("collapse", "critical", JAMARAT),  # at the bridge
        ("collapse", "low", (21.4230, 39.8733)),  # ~56 m north
        ("fire", "high", (21.4133, 39.8933)),  # ~2.3 km away
        ("lost_child", "high", None),  # no position
    ]
    for kind, severity, where in rows:
        place = {"lat": where[0], "lon": where[1]} if where else {}
        assert tools.call("incidents.log", {"kind": kind, "severity": severity, "description": "d", **place}).ok

    def kinds(**query: object) -> list[tuple[str, str]]:
        result = tools.call("incidents.query", query)
        assert result.ok, result.error
        return [(i["kind"], i["severity"]) for i in result.output["incidents"]]

    assert kinds(kind="collapse") == [("collapse", "low"), ("collapse", "critical")]
    assert kinds(min_severity="high") == [("lost_child", "high"), ("fire", "high"), ("collapse", "critical")]
    assert kinds(min_severity="critical") == [("collapse", "critical")]
    assert kinds(near={"lat": JAMARAT[0], "lon": JAMARAT[1], "radius_m": 100}) == [
        ("collapse", "low"),
        ("collapse", "critical"),
    ]
    assert kinds(near={"lat": JAMARAT[0], "lon": JAMARAT[1], "radius_m": 5000}, min_severity="high") == [
        ("fire", "high"),
        ("collapse", "critical"),
    ]
    assert kinds(limit=2) == [("lost_child", "high"), ("fire", "high")]
    future = (datetime.now(UTC) + timedelta(hours=1)).isoformat()
    past = (datetime.now(UTC) - timedelta(hours=1)).isoformat().replace("+00:00", "Z")
    assert kinds(since=future) == []
    assert len(kinds(since=past)) == 4
    near = tools.call("incidents.query", {"near": {"lat": JAMARAT[0], "lon": JAMARAT[1], "radius_m": 100}})
    distances = [i["distance_m"] for i in near.output["incidents"]]
    assert distances[1] == 0.0 and 50 < distances[0] < 60


def test_bad_queries_and_positions_are_errors(
    config: BuiltinConfig, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    tools = harness(config)
    result = tools.call("incidents.query", {"since": "yesterday"})
    assert result.status == "error" and "ISO 8601" in (result.error or "")
    result = tools.call("incidents.log", {"kind": "fire", "severity": "high", "description": "d", "lat": 21.0})
    assert result.status == "error" and "both lat and lon" in (result.error or "")
    result = tools.call("incidents.log", {"kind": "fire", "severity": "extreme", "description": "d"})
    assert result.status == "error" and "invalid arguments" in (result.error or "")


def test_concurrent_logging_keeps_every_row(config: BuiltinConfig, harness: Callable[[BuiltinConfig], Harness]) -> None:
    tools = harness(config)
    start = threading.Barrier(8)
    results: list[object] = []
    lock = threading.Lock()

    def report(n: int) -> None:
        caller = Caller(id=f"drone-{n}", scopes=frozenset({"incidents:write"}))
        start.wait()
        for k in range(5):
            result = tools.call(
                "incidents.log", {"kind": "density", "severity": "low", "description": f"{n}/{k}"}, caller=caller
            )
            with lock:
                results.append(result.output["id"] if result.ok else result.error)

    threads = [threading.Thread(target=report, args=(n,)) for n in range(8)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=60)
    assert len(results) == 40 and all(isinstance(r, int) for r in results), results
    assert len(set(results)) == 40
    found = tools.call("incidents.query", {"limit": 1000})
    assert found.output["count"] == 40
    assert {i["description"] for i in found.output["incidents"]} == {f"{n}/{k}" for n in range(8) for k in range(5)}
    with sqlite3.connect(config.incidents_db) as db:
        assert db.execute("PRAGMA journal_mode").fetchone() == ("wal",)


def test_scopes_guard_reading_and_writing(config: BuiltinConfig, harness: Callable[[BuiltinConfig], Harness]) -> None:
    tools = harness(config)
    reader = Caller(id="viewer", scopes=frozenset({"incidents:read"}))
    denied = tools.call("incidents.log", {"kind": "fire", "severity": "high", "description": "d"}, caller=reader)
    assert denied.status == "denied" and "incidents:write" in (denied.error or "")
    assert tools.call("incidents.query", {}, caller=reader).ok


def test_distance_is_the_wgs84_one() -> None:
    assert distance_m(0, 0, 0, 1) == pytest.approx(WGS84_A * math.pi / 180, rel=1e-12)  # one degree at the equator
    assert distance_m(*JAMARAT, *JAMARAT) == 0.0
