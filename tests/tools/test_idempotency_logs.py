"""Idempotency keys in the audit files: found again by a new process (after a restart, after SIGKILL), a huge output
bounded, a line cut short by a crash skipped with a warning, an older SQLite file upgraded in place."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import sqlite3
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from tools import (
    AuditRecord,
    JsonlAuditLog,
    MemoryAuditLog,
    SqliteAuditLog,
    ToolRegistry,
    open_audit_log,
    read_audit_log,
)
from tools.audit import AuditLogWarning
from tools.audit_index import KeyIndex
from tools.idempotency import KEPT_OUTPUT_LIMIT_BYTES

from .conftest import Counter, stage
from .executor_fixtures import MakeExecutor, schema_tool
from .idempotency_child import release_tool

KEY = "run-7:release:0"
REPO = Path(__file__).resolve().parents[2]


def sender(registry: ToolRegistry, counter: Counter, **options: Any) -> None:
    def send(args: dict[str, Any]) -> dict[str, Any]:
        return {"sent": args.get("text"), "run": counter.hit()}

    schema_tool(registry, "alerts.page", send, side_effects=True, **options)


def record(call_id: str, key: str | None, status: str = "ok", output: Any = None) -> AuditRecord:
    return AuditRecord(
        time="2025-06-05T12:00:00+00:00", call_id=call_id, caller="pilot", tool="alerts.page", args={},
        status=status, latency_s=0.01, attempts=1, cached=False, error=None, stages=[], idempotency_key=key,
        side_effects=True, output=output, output_kept=output is not None,
    )  # fmt: skip


# a restart ----------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("suffix", ["jsonl", "db"])
def test_a_reopened_log_replays_the_key_after_a_restart(
    suffix: str, tmp_path: Path, make_executor: MakeExecutor
) -> None:
    path = tmp_path / f"audit.{suffix}"
    before, after = Counter(), Counter()
    registry = ToolRegistry()
    sender(registry, before)
    with contextlib.closing(open_audit_log(path)) as log:
        first = make_executor(registry, audit=log).call("alerts.page", {"text": "t"}, idempotency_key=KEY)
    restarted = ToolRegistry()
    sender(restarted, after)
    with contextlib.closing(open_audit_log(path)) as log:
        executor = make_executor(restarted, audit=log)
        again = executor.call("alerts.page", {"text": "t"}, idempotency_key=KEY)
        fresh = executor.call("alerts.page", {"text": "t"}, idempotency_key="run-8:release:0")
        once_more = executor.call("alerts.page", {"text": "t"}, idempotency_key=KEY)
    assert (before.runs, after.runs) == (1, 1)
    assert again.replayed and again.output == first.output == {"sent": "t", "run": 1}
    assert fresh.ok and not fresh.replayed and fresh.output == {"sent": "t", "run": 1}
    assert once_more.replayed and once_more.output == first.output


def test_a_jsonl_log_finds_keys_another_writer_appended_after_it_opened(tmp_path: Path) -> None:
    path = tmp_path / "audit.jsonl"
    reader, writer = JsonlAuditLog(path), JsonlAuditLog(path)
    try:
        assert reader.find(KEY) is None  # indexed now: the writer's record comes later
        writer.write(record("c-1", KEY, output={"n": 1}))
        found = reader.find(KEY)
        assert found is not None and (found.call_id, found.output) == ("c-1", {"n": 1})
    finally:
        reader.close()
        writer.close()


@pytest.mark.parametrize("suffix", ["jsonl", "db"])
def test_find_prefers_the_first_ok_call_then_the_latest(suffix: str, tmp_path: Path) -> None:
    path = tmp_path / f"audit.{suffix}"
    with contextlib.closing(open_audit_log(path)) as log:
        log.write(record("c-1", KEY, status="timeout"))
        log.write(record("c-2", KEY, status="error"))
        failed = log.find(KEY, "alerts.page")
        log.write(record("c-3", KEY, output={"n": 3}))
        log.write(record("c-4", KEY, output={"n": 4}))
        log.write(record("c-5", "other-key"))
    with contextlib.closing(open_audit_log(path)) as log:
        found, other_tool, unknown = log.find(KEY, "alerts.page"), log.find(KEY, "alerts.mail"), log.find("nope")
        any_tool = log.find(KEY)
    assert failed is not None and failed.call_id == "c-2"
    assert found is not None and any_tool is not None and (found.call_id, any_tool.call_id) == ("c-3", "c-3")
    assert found.output == {"n": 3} and other_tool is None and unknown is None


# SIGKILL right after the call -------------------------------------------------------------------------------------
@pytest.mark.parametrize("suffix", ["jsonl", "db"])
def test_a_key_survives_sigkill_right_after_the_call(suffix: str, tmp_path: Path, make_executor: MakeExecutor) -> None:
    audit, runs = tmp_path / f"audit.{suffix}", tmp_path / "runs.txt"
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    child = subprocess.run(
        [sys.executable, "-m", "tests.tools.idempotency_child", str(audit), str(runs), KEY],
        cwd=REPO, env=env, capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert child.returncode == -signal.SIGKILL, child.stderr
    in_child = json.loads(child.stdout)
    assert in_child["status"] == "ok" and in_child["output"]["run"] == 1
    registry = ToolRegistry()
    registry.register(release_tool(runs))
    with contextlib.closing(open_audit_log(audit)) as log:
        again = make_executor(registry, audit=log).call("payload.release", {"bay": 2}, idempotency_key=KEY)
    assert again.ok and again.replayed and again.output == in_child["output"]
    assert runs.read_text().splitlines() == [str(in_child["output"]["pid"])]  # released once, by the child


def test_a_side_effect_record_is_fsynced_before_the_call_returns(
    tmp_path: Path, make_executor: MakeExecutor, monkeypatch: pytest.MonkeyPatch
) -> None:
    synced: list[int] = []
    real_fsync = os.fsync

    def spy(fd: int) -> None:
        synced.append(fd)
        real_fsync(fd)

    monkeypatch.setattr("tools.audit.os.fsync", spy)
    registry = ToolRegistry()
    sender(registry, Counter())
    schema_tool(registry, "svc.read", lambda args: 1)
    with contextlib.closing(JsonlAuditLog(tmp_path / "audit.jsonl")) as log:
        executor = make_executor(registry, audit=log)
        executor.call("svc.read", {}, idempotency_key=KEY)
        assert synced == []  # a plain call is flushed to the OS, not forced to disk
        executor.call("alerts.page", {})
        assert len(synced) == 1  # every side-effect call, with a key or without
        executor.call("alerts.page", {}, idempotency_key=KEY)
        assert len(synced) == 2
        assert executor.call("alerts.page", {}, idempotency_key=KEY).replayed
        assert len(synced) == 2  # a replay acted on nothing: no need to force it to disk


# bounds ---------------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("suffix", ["jsonl", "db"])
def test_a_huge_output_is_not_kept_and_still_not_sent_twice(
    suffix: str, tmp_path: Path, make_executor: MakeExecutor
) -> None:
    counter = Counter()
    huge = "x" * (KEPT_OUTPUT_LIMIT_BYTES * 4)
    registry = ToolRegistry()
    schema_tool(registry, "alerts.dump", lambda args: {"run": counter.hit(), "echo": huge}, side_effects=True)
    path = tmp_path / f"audit.{suffix}"
    with contextlib.closing(open_audit_log(path)) as log:
        executor = make_executor(registry, audit=log)
        first = executor.call("alerts.dump", {}, idempotency_key=KEY)
        again = executor.call("alerts.dump", {}, idempotency_key=KEY)
    assert first.output == {"run": 1, "echo": huge}  # the caller gets it all; the log does not keep it
    assert again.replayed and again.output is None and counter.runs == 1
    assert "not kept" in str(stage(again, "idempotency").detail)
    assert path.stat().st_size < KEPT_OUTPUT_LIMIT_BYTES  # the log stays small
    kept = read_audit_log(path)[0]
    assert (kept.output, kept.output_kept, kept.idempotency_key) == (None, False, KEY)


def test_an_output_at_the_limit_is_kept(make_executor: MakeExecutor) -> None:
    registry = ToolRegistry()
    text = "y" * (KEPT_OUTPUT_LIMIT_BYTES - 2)  # with its quotes, exactly the limit in JSON
    schema_tool(registry, "alerts.fit", lambda args: text, side_effects=True)
    executor = make_executor(registry)
    executor.call("alerts.fit", {}, idempotency_key=KEY)
    assert executor.call("alerts.fit", {}, idempotency_key=KEY).output == text


def test_secrets_in_the_recorded_output_are_redacted(make_executor: MakeExecutor) -> None:
    registry = ToolRegistry()
    receipt = {"ticket": "T-9", "api_token": "tok-0123456789", "nested": {"pin": "4321", "ok": True}}
    schema_tool(registry, "alerts.ticket", lambda args: receipt, side_effects=True, sensitive_args=["pin"])
    audit = MemoryAuditLog()
    executor = make_executor(registry, audit=audit)
    first = executor.call("alerts.ticket", {}, idempotency_key=KEY)
    again = executor.call("alerts.ticket", {}, idempotency_key=KEY)
    assert first.output == receipt  # the caller that made the call gets the real output
    hidden = {"ticket": "T-9", "api_token": "[redacted]", "nested": {"pin": "[redacted]", "ok": True}}
    assert audit.records[0].output == hidden and again.output == hidden and again.replayed


def test_the_memory_log_forgets_the_keys_of_the_records_it_drops() -> None:
    log = MemoryAuditLog(max_records=2)
    log.write(record("c-1", KEY, output={"n": 1}))
    log.write(record("c-2", "k-2"))
    assert log.find(KEY) is not None
    log.write(record("c-3", "k-3"))
    assert log.find(KEY) is None and log.dropped == 1 and log.find("k-3") is not None


# a crash mid-write --------------------------------------------------------------------------------------------------
def test_a_cut_short_last_line_is_skipped_with_a_warning(tmp_path: Path, make_executor: MakeExecutor) -> None:
    path = tmp_path / "audit.jsonl"
    counter = Counter()
    registry = ToolRegistry()
    sender(registry, counter)
    with contextlib.closing(JsonlAuditLog(path)) as log:
        make_executor(registry, audit=log).call("alerts.page", {"text": "t"}, idempotency_key=KEY)
    whole = record("c-9", "run-7:release:1", output={"n": 9}).model_dump_json().encode()
    with path.open("ab") as file:
        file.write(whole[: len(whole) // 2])  # what a kill in the middle of a write leaves
    with pytest.warns(AuditLogWarning, match="cut short"), contextlib.closing(JsonlAuditLog(path)) as log:
        executor = make_executor(registry, audit=log)
        with pytest.warns(AuditLogWarning, match=r"audit\.jsonl:2: skipped a line"):
            replayed = executor.call("alerts.page", {"text": "t"}, idempotency_key=KEY)
        cut = executor.call("alerts.page", {"text": "t"}, idempotency_key="run-7:release:1")
        after = executor.call("alerts.page", {"text": "t"}, idempotency_key="run-7:release:1")
    assert replayed.replayed and not cut.replayed and after.replayed and counter.runs == 2
    with pytest.warns(AuditLogWarning, match=r":2: skipped a line that is not an audit record"):
        records = read_audit_log(path)
    assert [r.idempotency_key for r in records] == [KEY, KEY, "run-7:release:1", "run-7:release:1"]


def test_garbage_lines_anywhere_are_skipped_not_fatal(tmp_path: Path) -> None:
    path = tmp_path / "audit.jsonl"
    good = record("c-1", KEY, output={"n": 1}).model_dump_json()
    path.write_text("\n".join(["{not json", good, "[1, 2]", '{"idempotency_key": 5, "tool": "x"}', "\x00\x01"]) + "\n")
    with pytest.warns(AuditLogWarning) as caught, contextlib.closing(JsonlAuditLog(path)) as log:
        found = log.find(KEY)
    assert found is not None and found.call_id == "c-1"
    assert sorted(str(w.message).split(": skipped")[0].rsplit(":", 1)[1] for w in caught) == ["1", "3", "4", "5"]


# an older SQLite file -----------------------------------------------------------------------------------------------
OLD_SCHEMA = """
CREATE TABLE tool_calls (
    seq INTEGER PRIMARY KEY AUTOINCREMENT, time TEXT NOT NULL, call_id TEXT NOT NULL, caller TEXT NOT NULL,
    tool TEXT NOT NULL, args TEXT NOT NULL, status TEXT NOT NULL, latency_s REAL NOT NULL, attempts INTEGER NOT NULL,
    cached INTEGER NOT NULL, error TEXT, stages TEXT NOT NULL);
INSERT INTO tool_calls (time, call_id, caller, tool, args, status, latency_s, attempts, cached, error, stages)
    VALUES ('2025-06-01T00:00:00+00:00', 'old-1', 'pilot', 'svc.read', '{}', 'ok', 0.1, 1, 0, NULL, '[]');
"""


def test_an_sqlite_log_written_before_keys_existed_is_upgraded(tmp_path: Path) -> None:
    path = tmp_path / "audit.db"
    db = sqlite3.connect(path)
    db.executescript(OLD_SCHEMA)
    db.close()
    assert [r.call_id for r in read_audit_log(path)] == ["old-1"]  # readable before the upgrade
    with contextlib.closing(SqliteAuditLog(path)) as log:
        log.write(record("c-1", KEY, output={"n": 1}))
        found = log.find(KEY)
        with pytest.raises(sqlite3.DatabaseError, match="append-only"):
            log._db.execute("UPDATE tool_calls SET status = 'error'")
    old, new = read_audit_log(path)
    assert (old.call_id, old.idempotency_key, old.side_effects, old.output_kept) == ("old-1", None, False, False)
    assert found is not None and found == new and new.output == {"n": 1}


def test_the_key_index_keeps_each_tool_of_a_key_apart() -> None:
    index: KeyIndex[str] = KeyIndex()
    index.add(KEY, "alerts.page", "p-error", False, 1)
    index.add(KEY, "alerts.mail", "m-ok", True, 2)
    index.add(KEY, "alerts.page", "p-ok", True, 3)
    index.add(KEY, "alerts.mail", "m-later", False, 4)
    index.add(KEY, "incidents.log", "i-error", False, 5)
    assert [index.best(KEY, t) for t in ("alerts.page", "alerts.mail", "incidents.log")] == ["p-ok", "m-ok", "i-error"]
    assert index.best(KEY) == "m-ok"  # the first completed call, whatever its tool
    index.discard(KEY, "alerts.mail", "m-ok")
    assert index.best(KEY, "alerts.mail") is None and index.best(KEY) == "p-ok"
    index.discard(KEY, "alerts.page", "not-this-one")
    assert index.best(KEY, "alerts.page") == "p-ok"
    index.discard(KEY, "alerts.page", "p-ok")
    assert index.best(KEY) == "i-error" and len(index) == 1
    index.discard(KEY, "incidents.log", "i-error")
    assert index.best(KEY) is None and len(index) == 0
