"""The audit log and the ok path it records: call ids, a failing log, internal errors that stay results, 8 threads
writing at once, and the mission dispatcher whose calls it records."""

import threading
from typing import Any

import pytest

from agentic_core.mission import Environment, compile_mission, initial_state, load_mission
from tools import AuditRecord, MemoryAuditLog, ToolRegistry, ToolResult

from .conftest import OK_STAGES, PILOT, stage, stage_names
from .executor_fixtures import GOTO, MakeExecutor, hammer


# ok ---------------------------------------------------------------------------------------------------------------
def test_ok(samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    audit = MemoryAuditLog()
    executor = make_executor(samples, audit=audit)
    result = executor.call("math.add", {"a": 2, "b": 3}, call_id="c-1")
    assert isinstance(result, ToolResult)
    assert (result.status, result.output, result.error) == ("ok", 5, None)
    assert (result.attempts, result.call_id, result.tool, result.caller) == (1, "c-1", "math.add", "anonymous")
    assert result.cached is False and result.untrusted is False and result.injection is None
    assert result.retry_after_s is None and result.latency_s >= 0
    assert stage_names(result) == OK_STAGES
    [record] = audit.records
    assert (record.call_id, record.tool, record.status, record.args) == ("c-1", "math.add", "ok", {"a": 2, "b": 3})
    assert record.stages == OK_STAGES[:-1]  # written before the audit stage itself is known


def test_every_call_gets_a_fresh_call_id(samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    executor = make_executor(samples)
    ids = {executor.call("math.add", {"a": 1, "b": 1}).call_id for _ in range(20)}
    assert len(ids) == 20


# internal errors never raise --------------------------------------------------------------------------------------
class BrokenAudit:
    def write(self, record: AuditRecord) -> None:
        raise OSError("disk full")

    def close(self) -> None:
        pass


def test_a_failing_audit_log_still_returns_the_result(samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    executor = make_executor(samples, audit=BrokenAudit())
    result = executor.call("math.add", {"a": 1, "b": 2})
    assert result.ok and result.output == 3
    assert stage_names(result)[-1] == "audit:failed"
    assert stage(result, "audit").detail == "OSError: disk full"
    assert executor.call("nope.nope", {}).stages[-1].outcome == "failed"


def test_an_internal_error_is_a_result(
    samples: ToolRegistry, make_executor: MakeExecutor, monkeypatch: pytest.MonkeyPatch
) -> None:
    def broken_scan(value: Any, **kwargs: Any) -> Any:
        raise RuntimeError("scanner crashed")

    monkeypatch.setattr("tools.executor.scan_value", broken_scan)
    result = make_executor(samples).call("math.add", {"a": 1, "b": 2}, call_id="c-9")
    assert result.status == "error" and result.call_id == "c-9" and result.tool == "math.add"
    assert result.error == "internal error in the tool executor: RuntimeError: scanner crashed"


# concurrency ------------------------------------------------------------------------------------------------------
def test_audit_under_8_threads(samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    audit = MemoryAuditLog()
    executor = make_executor(samples, audit=audit)
    ids: list[str] = []
    lock = threading.Lock()

    def work(index: int) -> None:
        for i in range(25):
            result = executor.call("math.add", {"a": index, "b": i})
            assert result.ok and result.output == index + i
            with lock:
                ids.append(result.call_id)

    hammer(8, work)
    assert len(ids) == 200 and sorted(ids) == sorted(r.call_id for r in audit.records)


# the mission dispatcher -------------------------------------------------------------------------------------------
def test_dispatcher_has_the_mission_runtime_signature(samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    executor = make_executor(samples)
    dispatch = executor.dispatcher(PILOT)
    result = dispatch("math.add", {"a": 1, "b": 2}, 5.0)
    assert isinstance(result, ToolResult) and result.ok and result.output == 3 and result.caller == "pilot"
    assert dispatch("math.add", {"a": 1, "b": 2}, None).ok
    assert executor.dispatcher()("flight.goto", GOTO, None).status == "denied"  # the executor's default caller


MISSION = """
plan_id: tools-dispatch
goal: run tools through the executor
steps:
  - {id: total, action: call_tool, tool: math.add, args: {a: 2, b: 3}, timeout_s: 5}
  - {id: echoed, action: call_tool, tool: svc.echo, depends_on: [total], args: {sum: "${total}"}}
"""


def test_a_mission_runs_its_tools_through_the_dispatcher(samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    audit = MemoryAuditLog()
    executor = make_executor(samples, audit=audit)
    plan = load_mission(MISSION, file="test.yaml")
    app = compile_mission(plan, Environment(dispatch=executor.dispatcher(PILOT)))
    out = app.invoke(initial_state(plan), {"recursion_limit": 100})
    assert out["status"] == {"total": "ok", "echoed": "ok"}
    assert out["outputs"]["total"] == 5
    assert out["outputs"]["echoed"] == {"sum": 5}
    assert [r.tool for r in audit.records] == ["math.add", "svc.echo"]
    assert all(r.caller == "pilot" for r in audit.records)
