"""The end of every call, at whatever stage it stopped: its audit record written (secrets redacted, a side-effect
call's output kept for replay) and its :class:`ToolResult` made. A failing audit log is a failed ``audit`` stage,
never a lost result."""

from __future__ import annotations

import time
from datetime import UTC, datetime
from typing import Any

from .attempts import CallState
from .audit import AuditLog, AuditRecord, redact, secret_values
from .idempotency import kept_output, key_problem
from .result import ToolResult, ToolStatus, construct
from .security import InjectionReport


def describe(exc: BaseException) -> str:
    """An exception in a few words: its type, and its message when it has one."""
    text = str(exc)
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def finish(
    audit: AuditLog,
    call: CallState,
    status: ToolStatus,
    *,
    output: Any = None,
    error: str | None = None,
    retry: float | None = None,
    cached: bool = False,
    injection: InjectionReport | None = None,
    replay_of: str | None = None,
) -> ToolResult:
    """End ``call`` with ``status``: its audit record written to ``audit``, its :class:`ToolResult` returned."""
    latency = time.perf_counter() - call.started
    sensitive = call.entry.spec.sensitive_args if call.entry is not None else frozenset()
    side_effects = call.entry is not None and call.entry.spec.side_effects
    kept, output_kept = None, False
    if side_effects and status == "ok" and replay_of is None:
        kept, output_kept, _ = kept_output(output, sensitive)
    if call.args and error is not None:
        for secret in secret_values(call.args, sensitive):  # an error quoting a password must not spread it
            error = error.replace(secret, "[redacted]")
            for stage in call.stages:
                stage.detail = stage.detail and stage.detail.replace(secret, "[redacted]")
    record = construct(
        AuditRecord,
        dict(
            time=datetime.now(UTC).isoformat(timespec="microseconds"),
            call_id=call.call_id,
            caller=call.caller.id,
            tool=call.name,
            args=redact(call.args, sensitive),
            status=status,
            latency_s=latency,
            attempts=call.attempts,
            cached=cached,
            error=error,
            stages=[f"{s.name}:{s.outcome}" for s in call.stages],
            idempotency_key=call.key if call.key is None or key_problem(call.key) is None else None,
            side_effects=side_effects,
            output=kept,
            output_kept=output_kept,
            replay_of=replay_of,
        ),
    )
    try:
        audit.write(record)
        call.stage("audit", "passed")
    except Exception as exc:
        call.stage("audit", "failed", describe(exc))
    return construct(
        ToolResult,
        dict(
            status=status,
            output=output,
            error=error,
            latency_s=latency,
            attempts=call.attempts,
            call_id=call.call_id,
            tool=call.name,
            caller=call.caller.id,
            cached=cached,
            replayed=replay_of is not None,
            retry_after_s=retry,
            stages=call.stages,
            untrusted=injection is not None or (call.entry is not None and call.entry.spec.untrusted_output),
            injection=injection,
        ),
    )


def internal_error(audit: AuditLog, call: CallState, exc: Exception) -> ToolResult:
    """The result of a call that a bug of the executor broke off (a bare one when even finishing it fails)."""
    error = f"internal error in the tool executor: {describe(exc)}"
    try:
        return finish(audit, call, "error", error=error)
    except Exception:
        return ToolResult(
            status="error", error=error, latency_s=0.0, attempts=call.attempts, call_id=call.call_id, tool=call.name
        )


__all__ = ["describe", "finish", "internal_error"]
