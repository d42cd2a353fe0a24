"""Idempotency keys in the executor: a side-effect tool acts once per key, whatever tries to make it act twice
(a second call, a restart on the same audit file, two threads or tasks at once), and only an ok call is replayed."""

from __future__ import annotations

import asyncio
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from tools import (
    AuditLog,
    AuditRecord,
    Caller,
    JsonlAuditLog,
    MemoryAuditLog,
    ToolContext,
    ToolDefinitionError,
    ToolError,
    ToolRegistry,
    ToolResult,
    open_audit_log,
    read_audit_log,
)
from tools.idempotency import MAX_KEY_LENGTH

from .conftest import PILOT, Counter, stage, stage_names
from .executor_fixtures import BEFORE_TOOL, MakeExecutor, hammer, schema_tool

KEY = "run-7:alert:0"


def wait_until(condition: Callable[[], bool], timeout_s: float = 10.0) -> None:
    """Return once ``condition()`` holds; fail the test when it has not within ``timeout_s``."""
    limit = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < limit, "the condition never came true"
        time.sleep(0.002)


def sender(registry: ToolRegistry, counter: Counter, name: str = "alerts.page", **options: Any) -> None:
    """A side-effect tool that counts its runs and answers with a receipt naming the run."""

    def send(args: dict[str, Any]) -> dict[str, Any]:
        run = counter.hit()
        return {"sent": args.get("text"), "run": run}

    options.setdefault("side_effects", True)
    schema_tool(registry, name, send, **options)


@pytest.fixture(params=["memory", "jsonl", "sqlite"])
def audit(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[AuditLog]:
    """Each kind of audit log."""
    log: AuditLog = MemoryAuditLog() if request.param == "memory" else open_audit_log(tmp_path / f"a.{request.param}")
    yield log
    log.close()


# one process ------------------------------------------------------------------------------------------------------
def test_a_second_call_with_the_key_is_replayed(
    registry: ToolRegistry, make_executor: MakeExecutor, audit: AuditLog
) -> None:
    counter = Counter()
    sender(registry, counter)
    executor = make_executor(registry, audit=audit)
    first = executor.call("alerts.page", {"text": "crowd at gate 3"}, idempotency_key=KEY, call_id="c-1")
    second = executor.call("alerts.page", {"text": "crowd at gate 3"}, idempotency_key=KEY, call_id="c-2")
    assert counter.runs == 1
    receipt = {"sent": "crowd at gate 3", "run": 1}
    assert (first.status, first.output, first.replayed, first.attempts) == ("ok", receipt, False, 1)
    assert (second.status, second.output, second.replayed, second.attempts) == ("ok", first.output, True, 0)
    assert stage_names(first)[3] == "idempotency:miss"
    assert stage_names(second) == [*BEFORE_TOOL, "idempotency:hit", "audit:passed"]
    assert stage(second, "idempotency").detail is not None and "c-1" in str(stage(second, "idempotency").detail)
    found = audit.find(KEY, "alerts.page")
    assert found is not None and (found.call_id, found.output, found.output_kept) == ("c-1", first.output, True)


def test_the_audit_records_the_key_the_output_and_the_replay(
    registry: ToolRegistry, make_executor: MakeExecutor, tmp_path: Path
) -> None:
    counter = Counter()
    sender(registry, counter)
    log = JsonlAuditLog(tmp_path / "audit.jsonl")
    executor = make_executor(registry, audit=log)
    executor.call("alerts.page", {"text": "t"}, idempotency_key=KEY, call_id="c-1")
    executor.call("alerts.page", {"text": "t"}, idempotency_key=KEY, call_id="c-2")
    log.close()
    first, second = read_audit_log(tmp_path / "audit.jsonl")
    assert (first.idempotency_key, first.side_effects, first.output_kept, first.replay_of) == (KEY, True, True, None)
    assert first.output == {"sent": "t", "run": 1}
    assert (second.idempotency_key, second.status, second.replay_of, second.attempts) == (KEY, "ok", "c-1", 0)
    assert second.output is None and not second.output_kept  # the output is kept once, with the call that made it


def test_a_different_key_acts_again(registry: ToolRegistry, make_executor: MakeExecutor, audit: AuditLog) -> None:
    counter = Counter()
    sender(registry, counter)
    executor = make_executor(registry, audit=audit)
    results = [executor.call("alerts.page", {"text": "t"}, idempotency_key=f"run-7:alert:{n}") for n in range(3)]
    assert counter.runs == 3 and [r.output["run"] for r in results] == [1, 2, 3]
    assert not any(r.replayed for r in results)
    assert executor.call("alerts.page", {"text": "t"}).output["run"] == 4  # no key: no protection asked for


def test_the_key_of_another_tool_is_not_a_replay(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    pages, mails = Counter(), Counter()
    sender(registry, pages, "alerts.page")
    sender(registry, mails, "alerts.mail")
    executor = make_executor(registry)
    assert executor.call("alerts.page", {}, idempotency_key=KEY).ok
    other = executor.call("alerts.mail", {}, idempotency_key=KEY)
    assert other.ok and not other.replayed and (pages.runs, mails.runs) == (1, 1)
    assert executor.call("alerts.mail", {}, idempotency_key=KEY).replayed and mails.runs == 1


def test_a_tool_without_side_effects_runs_every_time_and_records_the_key(
    registry: ToolRegistry, make_executor: MakeExecutor, audit: AuditLog
) -> None:
    counter = Counter()
    sender(registry, counter, "svc.read", side_effects=False)
    executor = make_executor(registry, audit=audit)
    results = [executor.call("svc.read", {}, idempotency_key=KEY) for _ in range(3)]
    assert counter.runs == 3 and not any(r.replayed for r in results)
    assert all("idempotency" not in [s.name for s in r.stages] for r in results)
    found = audit.find(KEY)
    assert found is not None and found.idempotency_key == KEY and found.tool == "svc.read"
    assert not found.side_effects and not found.output_kept and found.output is None


# a call that did not end ok is not replayed -------------------------------------------------------------------------
def test_a_failed_first_call_is_run_again_for_real(
    registry: ToolRegistry, make_executor: MakeExecutor, audit: AuditLog
) -> None:
    counter = Counter()

    def flaky(args: dict[str, Any]) -> dict[str, int]:
        if counter.hit() == 1:
            raise ToolError("mail server said 554")
        return {"run": counter.runs}

    schema_tool(registry, "alerts.flaky", flaky, side_effects=True)
    executor = make_executor(registry, audit=audit)
    failed = executor.call("alerts.flaky", {}, idempotency_key=KEY, call_id="c-1")
    retried = executor.call("alerts.flaky", {}, idempotency_key=KEY, call_id="c-2")
    replayed = executor.call("alerts.flaky", {}, idempotency_key=KEY, call_id="c-3")
    assert (failed.status, retried.status, replayed.status) == ("error", "ok", "ok")
    assert (retried.replayed, retried.output) == (False, {"run": 2})
    assert stage(retried, "idempotency").detail == "call c-1 with this key ended error: runs again"
    assert (replayed.replayed, replayed.output, counter.runs) == (True, {"run": 2}, 2)
    later_failure = audit.find(KEY, "alerts.flaky")
    assert later_failure is not None and later_failure.call_id == "c-2"  # the ok call decides, not the first


def test_a_denied_call_does_not_count_and_a_replay_is_still_authorized(
    registry: ToolRegistry, make_executor: MakeExecutor
) -> None:
    counter = Counter()
    sender(registry, counter, scopes=["alerts:send"])
    executor = make_executor(registry)
    guest = Caller(id="guest")
    assert executor.call("alerts.page", {}, idempotency_key=KEY, caller=guest).status == "denied"
    assert counter.runs == 0
    ran = executor.call("alerts.page", {}, idempotency_key=KEY, caller=PILOT)
    assert ran.ok and not ran.replayed and counter.runs == 1
    refused = executor.call("alerts.page", {}, idempotency_key=KEY, caller=guest)
    assert refused.status == "denied" and refused.output is None  # the key does not open the recorded output


def test_a_timed_out_call_is_run_again(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    counter = Counter()
    release = threading.Event()

    def slow(args: dict[str, Any]) -> str:
        if counter.hit() == 1:
            release.wait(10)
        return "sent"

    schema_tool(registry, "alerts.slow", slow, side_effects=True, timeout_s=0.05)
    executor = make_executor(registry)
    try:
        first = executor.call("alerts.slow", {}, idempotency_key=KEY)
        second = executor.call("alerts.slow", {}, idempotency_key=KEY)
    finally:
        release.set()
    assert first.status == "timeout" and second.ok and not second.replayed and counter.runs == 2


# two at once --------------------------------------------------------------------------------------------------------
def test_eight_threads_with_one_key_act_once(
    registry: ToolRegistry, make_executor: MakeExecutor, audit: AuditLog, monkeypatch: pytest.MonkeyPatch
) -> None:
    counter, waiting = Counter(), Counter()
    release = threading.Event()

    def send(args: dict[str, Any]) -> dict[str, int]:
        run = counter.hit()
        release.wait(10)  # held until the other seven are waiting for this call
        return {"run": run}

    schema_tool(registry, "alerts.page", send, side_effects=True)
    executor = make_executor(registry, audit=audit)
    gate_wait = executor._gate.wait

    def counted_wait(flight: Any, timeout: float | None) -> bool:
        waiting.hit()
        return gate_wait(flight, timeout)

    monkeypatch.setattr(executor._gate, "wait", counted_wait)
    results: list[ToolResult] = []
    lock = threading.Lock()

    def work(index: int) -> None:
        result = executor.call("alerts.page", {}, idempotency_key=KEY)
        with lock:
            results.append(result)

    worker = threading.Thread(target=hammer, args=(8, work))
    worker.start()
    try:
        wait_until(lambda: counter.runs == 1 and waiting.runs == 7)
    finally:
        release.set()
        worker.join(20)
    assert counter.runs == 1 and len(results) == 8 and all(r.ok for r in results)
    assert sorted(r.replayed for r in results) == [False] + [True] * 7
    assert all(r.output == {"run": 1} for r in results)


def test_a_waiting_call_gives_up_at_its_deadline_without_acting(
    registry: ToolRegistry, make_executor: MakeExecutor
) -> None:
    counter = Counter()
    release = threading.Event()
    schema_tool(registry, "alerts.page", lambda args: (counter.hit(), release.wait(10))[0], side_effects=True)
    executor = make_executor(registry, clock=time.monotonic)
    holder = threading.Thread(target=executor.call, args=("alerts.page", {}), kwargs={"idempotency_key": KEY})
    holder.start()
    try:
        wait_until(lambda: counter.runs == 1)
        impatient = executor.call("alerts.page", {}, idempotency_key=KEY, timeout_s=0.05)
    finally:
        release.set()
        holder.join(10)
    assert impatient.status == "timeout" and counter.runs == 1
    assert impatient.error is not None and "still running" in impatient.error and KEY in impatient.error
    assert stage_names(impatient)[-2:] == ["idempotency:failed", "audit:passed"]
    assert executor.call("alerts.page", {}, idempotency_key=KEY).replayed  # the first one's result, once it ended


def test_async_calls_with_one_key_act_once_and_keep_the_loop_running(
    registry: ToolRegistry, make_executor: MakeExecutor
) -> None:
    counter = Counter()

    async def scenario() -> tuple[list[ToolResult], int]:
        release = asyncio.Event()

        async def send(args: dict[str, Any]) -> dict[str, int]:
            run = counter.hit()
            await release.wait()
            return {"run": run}

        schema_tool(registry, "alerts.page", send, side_effects=True)
        executor = make_executor(registry)
        calls = [asyncio.create_task(executor.acall("alerts.page", {}, idempotency_key=KEY)) for _ in range(4)]
        ticks = 0
        while counter.runs < 1 or sum(len(f.waiters) for f in executor._gate._flights.values()) < 3:
            ticks += 1  # the loop runs while three calls wait: nothing blocks it
            assert ticks < 100_000, "the waiting calls never queued up"
            await asyncio.sleep(0)
        release.set()
        return list(await asyncio.gather(*calls)), ticks

    results, ticks = asyncio.run(scenario())
    assert counter.runs == 1 and ticks > 0
    assert sorted(r.replayed for r in results) == [False, True, True, True]
    assert all(r.ok and r.output == {"run": 1} for r in results)


def test_a_cancelled_waiter_leaves_the_key_usable(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    counter = Counter()

    async def scenario() -> ToolResult:
        release = asyncio.Event()

        async def send(args: dict[str, Any]) -> int:
            await release.wait()
            return counter.hit()

        schema_tool(registry, "alerts.page", send, side_effects=True)
        executor = make_executor(registry)
        first = asyncio.create_task(executor.acall("alerts.page", {}, idempotency_key=KEY))
        waiter = asyncio.create_task(executor.acall("alerts.page", {}, idempotency_key=KEY))
        while not any(f.waiters for f in executor._gate._flights.values()):
            await asyncio.sleep(0)
        waiter.cancel()
        with pytest.raises(asyncio.CancelledError):
            await waiter
        assert not any(f.waiters for f in executor._gate._flights.values())
        release.set()
        await first
        return await executor.acall("alerts.page", {}, idempotency_key=KEY)

    again = asyncio.run(scenario())
    assert again.replayed and again.output == 1 and counter.runs == 1


# bad keys, a log that cannot answer, the key in the tool's context --------------------------------------------------
@pytest.mark.parametrize(
    ("key", "message"),
    [
        (7, "idempotency_key must be a string, not int"),
        ("", "idempotency_key must not be empty"),
        ("  ", "idempotency_key must not be empty"),
        ("k" * (MAX_KEY_LENGTH + 1), f"idempotency_key is {MAX_KEY_LENGTH + 1} characters long; at most 256"),
    ],
)
def test_a_bad_key_is_refused_before_the_tool_runs(
    key: Any, message: str, registry: ToolRegistry, make_executor: MakeExecutor
) -> None:
    counter = Counter()
    sender(registry, counter)
    audit = MemoryAuditLog()
    result = make_executor(registry, audit=audit).call("alerts.page", {}, idempotency_key=key)
    assert (result.status, result.error, counter.runs) == ("error", f"invalid call: {message}", 0)
    assert stage_names(result) == ["lookup:passed", "validate_args:failed", "audit:passed"]
    unknown = make_executor(registry, audit=audit).call("alerts.pager", {}, idempotency_key=key)
    assert unknown.status == "error" and "did you mean 'alerts.page'" in str(unknown.error)
    assert [r.idempotency_key for r in audit.records] == [None, None]  # a bad key is never recorded as one


class UnreadableAudit(MemoryAuditLog):
    def find(self, idempotency_key: str, tool: str | None = None) -> AuditRecord | None:
        raise OSError("the audit disk is gone")


class NoFindAudit:
    """A log written before ``find`` existed."""

    def write(self, record: AuditRecord) -> None:
        pass

    def close(self) -> None:
        pass


@pytest.mark.parametrize("audit_log", [UnreadableAudit(), NoFindAudit()], ids=["find-fails", "no-find"])
def test_a_log_that_cannot_answer_refuses_rather_than_risk_acting_twice(
    audit_log: Any, registry: ToolRegistry, make_executor: MakeExecutor
) -> None:
    counter = Counter()
    sender(registry, counter)
    sender(registry, counter, "svc.read", side_effects=False)
    executor = make_executor(registry, audit=audit_log)
    refused = executor.call("alerts.page", {}, idempotency_key=KEY)
    assert refused.status == "error" and counter.runs == 0
    assert refused.error is not None and "cannot look up idempotency key" in refused.error
    assert stage_names(refused)[-2] == "idempotency:failed"
    assert executor.call("alerts.page", {}).ok and executor.call("svc.read", {}, idempotency_key=KEY).ok  # no lookup
    assert counter.runs == 2


def test_the_tool_receives_the_key_in_its_context(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    seen: list[str | None] = []

    def handler(args: dict[str, Any], context: ToolContext) -> None:
        seen.append(context.idempotency_key)

    schema_tool(registry, "svc.plain", handler)
    schema_tool(registry, "alerts.keyed", handler, side_effects=True)
    executor = make_executor(registry)
    executor.call("svc.plain", {}, idempotency_key="k-plain")
    executor.call("alerts.keyed", {}, idempotency_key="k-side")
    executor.call("alerts.keyed", {})
    assert seen == ["k-plain", "k-side", None]


def test_side_effects_must_be_a_bool_and_is_described(registry: ToolRegistry) -> None:
    with pytest.raises(ToolDefinitionError, match="side_effects must be True or False"):
        schema_tool(registry, "alerts.bad", lambda args: None, side_effects="yes")
    schema_tool(registry, "alerts.good", lambda args: None, side_effects=True)
    schema_tool(registry, "svc.good", lambda args: None)
    assert registry.describe("alerts.good").side_effects and not registry.describe("svc.good").side_effects
