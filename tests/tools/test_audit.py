"""The append-only audit log: redaction, JSONL and SQLite logs written by the executor and read back, refused
UPDATE and DELETE, file-suffix rules."""

import sqlite3
import threading
from collections.abc import Callable
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import pytest

from tools import (
    AuditRecord,
    JsonlAuditLog,
    MemoryAuditLog,
    SqliteAuditLog,
    ToolExecutor,
    ToolRegistry,
    ToolResult,
    ToolSpec,
    open_audit_log,
    read_audit_log,
)
from tools.audit import REDACTED, redact

from .conftest import PILOT

MakeExecutor = Callable[..., ToolExecutor]


# redaction --------------------------------------------------------------------------------------------------------
def test_redact_secret_looking_keys_at_any_depth() -> None:
    args = {
        "user": "ops",
        "password": "hunter2",
        "api_key": "k-1",
        "apiKey": "k-2",
        "X-API-Key": "k-3",
        "nested": {"client_secret": "s", "token": "t", "depth": {"private_key": "pk", "keep": 1}},
        "items": [{"passphrase": "p", "name": "a"}, ("Authorization", {"credentials": "c"})],
        "count": 3,
    }
    assert redact(args) == {
        "user": "ops",
        "password": REDACTED,
        "api_key": REDACTED,
        "apiKey": REDACTED,
        "X-API-Key": REDACTED,
        "nested": {"client_secret": REDACTED, "token": REDACTED, "depth": {"private_key": REDACTED, "keep": 1}},
        "items": [{"passphrase": REDACTED, "name": "a"}, ["Authorization", {"credentials": REDACTED}]],
        "count": 3,
    }
    assert args["password"] == "hunter2"  # the arguments themselves are left alone


def test_redact_sensitive_names_at_any_depth() -> None:
    args = {"pin": "1234", "drone": {"pin": "9999", "id": "d7"}, "note": "pin is private"}
    assert redact(args, frozenset({"pin"})) == {
        "pin": REDACTED,
        "drone": {"pin": REDACTED, "id": "d7"},
        "note": "pin is private",
    }
    assert redact("password") == "password" and redact([1, "x"]) == [1, "x"]


# the executor writes every call -----------------------------------------------------------------------------------
@pytest.fixture
def audited(registry: ToolRegistry) -> ToolRegistry:
    registry.register(
        ToolSpec.from_schema(
            "vault.login",
            lambda args: {"session": "ok"},
            {
                "type": "object",
                "properties": {
                    "user": {"type": "string"},
                    "password": {"type": "string"},
                    "pin": {"type": "string"},
                    "options": {"type": "object"},
                },
            },
            sensitive_args=["pin"],
            idempotent=True,
            cache_ttl_s=60,
            scopes=["vault:open"],
        )
    )

    def fail(args: dict[str, Any]) -> None:
        raise RuntimeError("backend down")

    registry.register(ToolSpec.from_schema("svc.down", fail, {"type": "object"}))
    return registry


LOGIN = {
    "user": "ops",
    "password": "hunter2",
    "pin": "PIN-SECRET",
    "options": {"api_key": "KEY-SECRET", "region": "mena"},
}
LOGIN_REDACTED = {
    "user": "ops",
    "password": REDACTED,
    "pin": REDACTED,
    "options": {"api_key": REDACTED, "region": "mena"},
}


def run_calls(executor: ToolExecutor) -> list[ToolResult]:
    return [
        executor.call("vault.login", LOGIN, caller=PILOT),  # ok
        executor.call("vault.login", LOGIN, caller=PILOT),  # cached
        executor.call("vault.login", LOGIN),  # denied
        executor.call("svc.down", {"token": "TOKEN-SECRET"}),  # error
        executor.call("vault.logon", {"password": "p"}),  # unknown tool: its arguments redacted too
    ]


def check_records(records: list[AuditRecord], results: list[ToolResult]) -> None:
    assert [r.call_id for r in records] == [r.call_id for r in results]
    assert [r.status for r in records] == ["ok", "ok", "denied", "error", "error"]
    assert [r.cached for r in records] == [False, True, False, False, False]
    assert [r.attempts for r in records] == [1, 0, 0, 1, 0]
    assert [r.caller for r in records] == ["pilot", "pilot", "anonymous", "anonymous", "anonymous"]
    assert [r.tool for r in records] == ["vault.login", "vault.login", "vault.login", "svc.down", "vault.logon"]
    assert [r.args for r in records[:3]] == [LOGIN_REDACTED] * 3
    assert records[3].args == {"token": REDACTED} and records[4].args == {"password": REDACTED}
    assert records[3].error == "RuntimeError: backend down" and records[0].error is None
    for record, result in zip(records, results, strict=True):
        assert record.stages == [f"{s.name}:{s.outcome}" for s in result.stages if s.name != "audit"]
        assert record.latency_s == pytest.approx(result.latency_s)
        stamp = datetime.fromisoformat(record.time)
        assert stamp.tzinfo is not None and stamp.utcoffset() == UTC.utcoffset(None)
        assert abs((datetime.now(UTC) - stamp).total_seconds()) < 60
    serialised = "".join(r.model_dump_json() for r in records)
    assert "hunter2" not in serialised and "SECRET" not in serialised


def test_memory_log_holds_every_call(audited: ToolRegistry, make_executor: MakeExecutor) -> None:
    audit = MemoryAuditLog()
    results = run_calls(make_executor(audited, audit=audit))
    check_records(audit.records, results)


@pytest.mark.parametrize("suffix", [".jsonl", ".db", ".sqlite"])
def test_file_logs_round_trip(suffix: str, tmp_path: Path, audited: ToolRegistry) -> None:
    path = tmp_path / "logs" / f"audit{suffix}"  # the parent directory is created
    executor = ToolExecutor(audited, audit=open_audit_log(path))
    try:
        results = run_calls(executor)
    finally:
        executor.close()  # closes the log too
    records = read_audit_log(path)
    check_records(records, results)
    stored = path.read_bytes().decode("utf-8", "replace")
    assert "hunter2" not in stored and "SECRET" not in stored


def test_jsonl_is_one_object_a_line_appended_across_opens(tmp_path: Path, audited: ToolRegistry) -> None:
    path = tmp_path / "audit.jsonl"
    for _ in range(2):
        executor = ToolExecutor(audited, audit=JsonlAuditLog(path))
        executor.call("svc.down", {})
        executor.close()
    lines = path.read_text(encoding="utf-8").splitlines()
    assert len(lines) == 2 and all(line.startswith("{") and line.endswith("}") for line in lines)
    assert len(read_audit_log(path)) == 2


def test_sqlite_refuses_update_and_delete(tmp_path: Path, audited: ToolRegistry) -> None:
    path = tmp_path / "audit.db"
    executor = ToolExecutor(audited, audit=SqliteAuditLog(path))
    executor.call("svc.down", {})
    executor.close()
    db = sqlite3.connect(path)
    try:
        with pytest.raises(sqlite3.DatabaseError, match="the audit log is append-only"):
            db.execute("UPDATE tool_calls SET status = 'ok'")
        with pytest.raises(sqlite3.DatabaseError, match="the audit log is append-only"):
            db.execute("DELETE FROM tool_calls")
        db.commit()
    finally:
        db.close()
    [record] = read_audit_log(path)
    assert record.status == "error"


def test_sqlite_reopen_appends(tmp_path: Path) -> None:
    path = tmp_path / "audit.sqlite3"
    for i in range(2):
        log = SqliteAuditLog(path)
        log.write(
            AuditRecord(
                time=datetime.now(UTC).isoformat(),
                call_id=f"c{i}",
                caller="x",
                tool="svc.t",
                args={"n": i},
                status="ok",
                latency_s=0.1,
                attempts=1,
                cached=False,
                error=None,
                stages=["lookup:passed"],
            )
        )
        log.close()
    assert [(r.call_id, r.args) for r in read_audit_log(path)] == [("c0", {"n": 0}), ("c1", {"n": 1})]


def test_sqlite_log_under_8_threads(tmp_path: Path, audited: ToolRegistry) -> None:
    path = tmp_path / "audit.db"
    executor = ToolExecutor(audited, audit=SqliteAuditLog(path))
    barrier = threading.Barrier(8)

    def work() -> None:
        barrier.wait()
        for _ in range(20):
            executor.call("svc.down", {"password": "p"})

    threads = [threading.Thread(target=work) for _ in range(8)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(10)
    executor.close()
    records = read_audit_log(path)
    assert len(records) == 160 and len({r.call_id for r in records}) == 160
    assert all(r.args == {"password": REDACTED} for r in records)


@pytest.mark.parametrize(
    ("args", "secret"),
    [
        ({"user": "ops", "password": "hunter2"}, "hunter2"),  # too short for the schema
        ({"user": "ops", "pin": "PIN-SECRET"}, "PIN-SECRET"),  # not four digits
    ],
)
def test_a_rejected_secret_does_not_leak_into_the_audit_log(
    args: dict[str, str], secret: str, registry: ToolRegistry, make_executor: MakeExecutor
) -> None:
    schema = {
        "type": "object",
        "properties": {
            "user": {"type": "string"},
            "password": {"type": "string", "minLength": 12},
            "pin": {"type": "string", "pattern": "^[0-9]{4}$"},
        },
    }
    registry.register(ToolSpec.from_schema("vault.open", lambda a: True, schema, sensitive_args=["pin"]))
    audit = MemoryAuditLog()
    result = make_executor(registry, audit=audit).call("vault.open", args)
    assert result.status == "error"
    [record] = audit.records
    assert secret not in record.model_dump_json()  # the error text quotes the rejected value


@pytest.mark.parametrize("suffix", [".jsonl", ".db"])
def test_arguments_without_a_json_form_are_still_audited(suffix: str, tmp_path: Path, registry: ToolRegistry) -> None:
    class Waypoint:
        def __repr__(self) -> str:
            return "Waypoint(21.4, 39.8)"

    registry.register(ToolSpec.from_schema("svc.echo", lambda args: "seen", {"type": "object"}))
    path = tmp_path / f"audit{suffix}"
    executor = ToolExecutor(registry, audit=open_audit_log(path))
    try:
        result = executor.call("svc.echo", {"where": Waypoint()})  # a Python caller may pass any object
    finally:
        executor.close()
    assert result.ok  # never an exception across the boundary
    assert result.stages[-1].outcome == "passed", result.stages[-1].detail
    [record] = read_audit_log(path)
    assert record.args == {"where": "Waypoint(21.4, 39.8)"}


# opening logs -----------------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("name", "kind"),
    [
        ("a.jsonl", JsonlAuditLog),
        ("a.JSONL", JsonlAuditLog),
        ("a.db", SqliteAuditLog),
        ("a.sqlite", SqliteAuditLog),
        ("a.sqlite3", SqliteAuditLog),
        ("a.DB", SqliteAuditLog),
    ],
)
def test_open_audit_log_by_suffix(name: str, kind: type, tmp_path: Path) -> None:
    log = open_audit_log(tmp_path / name)
    try:
        assert isinstance(log, kind)
    finally:
        log.close()


@pytest.mark.parametrize("name", ["a.txt", "a.json", "audit", "a.jsonl.bak"])
def test_open_audit_log_refuses_other_suffixes(name: str, tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"use a \.jsonl file or a \.db/\.sqlite file"):
        open_audit_log(tmp_path / name)
    assert not (tmp_path / name).exists()


def test_the_memory_log_keeps_the_latest_records_and_counts_the_rest() -> None:
    from tools import MemoryAuditLog, ToolExecutor, ToolRegistry

    registry = ToolRegistry()
    registry.register(ToolSpec.from_schema("svc.echo", lambda args: args.get("n"), {"type": "object"}))
    audit = MemoryAuditLog(max_records=3)
    executor = ToolExecutor(registry, audit=audit)
    try:
        for n in range(5):
            executor.call("svc.echo", {"n": n})
    finally:
        executor.close()
    assert [r.args for r in audit.records] == [{"n": 2}, {"n": 3}, {"n": 4}]
    assert audit.dropped == 2


@pytest.mark.parametrize("secret", ["C:\\S3cret\\Pass", "line1\nline2-secret", 'quote"d-secret'])
def test_a_secret_is_scrubbed_in_the_form_the_message_quotes_it(secret: str) -> None:
    from tools import MemoryAuditLog, ToolExecutor, ToolRegistry

    registry = ToolRegistry()
    registry.register(
        ToolSpec.from_schema(
            "a.login",
            lambda args: True,
            {"type": "object", "properties": {"user": {"type": "string"}, "password": {"type": "integer"}}},
        )
    )
    audit = MemoryAuditLog()
    executor = ToolExecutor(registry, audit=audit)
    try:
        result = executor.call("a.login", {"user": "bob", "password": secret})
    finally:
        executor.close()
    assert result.status == "error" and "[redacted]" in (result.error or "")
    for text in (result.error or "", audit.records[-1].error or "", *(s.detail or "" for s in result.stages)):
        assert "S3cret" not in text and "secret" not in text.replace("[redacted]", "")


@pytest.mark.parametrize(
    ("key", "secret"),
    [
        ("password", True),
        ("smtp_password", True),
        ("apiKey", True),
        ("X-Api-Key", True),
        ("access_token", True),
        ("accessToken", True),
        ("Authorization", True),
        ("client_secret", True),
        ("private_key", True),
        ("compass_heading", False),
        ("passenger_count", False),
        ("author", False),
        ("tokenizer", False),
        ("authority", False),
    ],
)
def test_secret_argument_names_are_told_apart_from_ordinary_ones(key: str, secret: bool) -> None:
    from tools.audit import is_secret_key

    assert is_secret_key(key) is secret


def test_secrets_are_redacted_by_name_and_by_shape() -> None:
    from tools.audit import REDACTED, redact

    jwt = "eyJhbGciOiJIUzI1NiIsInR5cCI6IkpXVCJ9.eyJzdWIiOiJvcGVyYXRvciJ9.SflKxwRJSMeKKF2QT4fwpMeJf36POk6yJV_adQssw5c"
    args = {
        "jwt": "anything",
        "access_key": "AKIA-short",
        "passcode": "1234",
        "signing_key": "k",
        "note": jwt,
        "nested": [{"header": f"Bearer {jwt}"}, "a" * 8 + "0123456789abcdef" * 2, "Kx9" * 15],
        "heading_deg": 90,
        "target": "casualty near the north gate",
        "compass": "north",
    }
    out = redact(args)
    for name in ("jwt", "access_key", "passcode", "signing_key", "note"):
        assert out[name] == REDACTED, name
    assert out["nested"][0]["header"] == REDACTED and out["nested"][1] == REDACTED and out["nested"][2] == REDACTED
    assert (out["heading_deg"], out["target"], out["compass"]) == (90, "casualty near the north gate", "north")
