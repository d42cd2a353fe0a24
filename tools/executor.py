"""One executor for every tool: lookup, argument validation, authorization, the idempotency key, rate limits,
cache, circuit breaker, retries with backoff, timeouts, the output's size bound, output validation, the injection
guard and the audit log, in that order.

Every call returns a :class:`ToolResult`; nothing raises across this boundary (but an ``acall`` cancelled by its
caller: the cancellation goes on, after the call is audited). The cache is consulted before the breaker, so a
cached answer is still served while a tool's breaker is open. The breaker counts one failure per call, after its
retries; a :class:`ToolError` is the tool's answer, not a sign of ill health. A side-effect tool called with an
``idempotency_key`` that its audit log records as ended ok is not run again: that result is replayed. An output
over ``max_output_bytes`` of JSON (1 MiB unless configured), or one that is not JSON data, is an error result
naming the tool and the size, found without serialising the output.
"""

from __future__ import annotations

import asyncio
import copy
import os
import time
from collections.abc import Awaitable, Callable, Mapping
from datetime import UTC, datetime
from typing import Any, Literal

from .arguments import argument_errors
from .attempts import AttemptRunner, CallState
from .audit import AuditLog, AuditRecord, MemoryAuditLog, completes, redact, secret_values
from .auth import ANONYMOUS, Caller, InvalidToken, TokenAuthority, unverified_caller
from .errors import DeadlinePassed, ToolError
from .idempotency import KEPT_OUTPUT_LIMIT_BYTES, Flight, GateKey, KeyGate, kept_output, key_problem
from .output_size import configured_limit, measure
from .registry import ToolRegistry, is_available
from .result import ToolResult, ToolStatus, construct
from .security import DEFAULT_THRESHOLD, InjectionReport, scan_value


def _describe(exc: BaseException) -> str:
    text = str(exc)
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


class ToolExecutor:
    """Runs registered tools behind their guards.

    >>> from tools import ToolRegistry, tool
    >>> registry = ToolRegistry()
    >>> @registry.tool(name="math.add")
    ... def add(a: int, b: int) -> int:
    ...     return a + b
    >>> executor = ToolExecutor(registry)
    >>> executor.call("math.add", {"a": 2, "b": 3}).output
    5
    >>> result = executor.call("math.add", {"a": "two", "b": 3})
    >>> result.status, result.error
    ('error', "invalid arguments: $.a: 'two' is not of type 'integer'")
    >>> executor.call("math.ad", {}).error
    "unknown tool 'math.ad'; did you mean 'math.add'?"

    A side-effect tool acts once per idempotency key; a re-run with the key gets the recorded result:

    >>> sent = []
    >>> @registry.tool(name="alerts.ping", side_effects=True)
    ... def ping(text: str) -> int:
    ...     sent.append(text)
    ...     return len(sent)
    >>> first = executor.call("alerts.ping", {"text": "hi"}, idempotency_key="run-1:ping:0")
    >>> again = executor.call("alerts.ping", {"text": "hi"}, idempotency_key="run-1:ping:0")
    >>> (first.output, first.replayed), (again.output, again.replayed), sent
    ((1, False), (1, True), ['hi'])
    """

    def __init__(
        self,
        registry: ToolRegistry,
        *,
        audit: AuditLog | None = None,
        authority: TokenAuthority | None = None,
        default_caller: Caller = ANONYMOUS,
        injection_threshold: float = DEFAULT_THRESHOLD,
        on_injection: Literal["flag", "withhold"] = "flag",
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
        async_sleep: Callable[[float], Awaitable[None]] = asyncio.sleep,
        max_output_bytes: int | None = None,
    ) -> None:
        """``max_output_bytes`` bounds a tool's answer as compact JSON (None: ``AGENTIC_UAV_MAX_TOOL_OUTPUT_BYTES``,
        else 1 MiB); a bigger answer is an error result, never held in memory several times over."""
        if max_output_bytes is None:
            max_output_bytes = configured_limit()
        if isinstance(max_output_bytes, bool) or not isinstance(max_output_bytes, int) or max_output_bytes <= 0:
            raise ValueError(f"max_output_bytes must be a positive number of bytes, not {max_output_bytes!r}")
        self.max_output_bytes = max_output_bytes
        self.registry = registry
        self._owns_audit = audit is None
        self.audit: AuditLog = audit if audit is not None else MemoryAuditLog()
        self.authority = authority
        self.default_caller = default_caller
        self.injection_threshold = injection_threshold
        self.on_injection = on_injection
        self.clock = clock
        self._runner = AttemptRunner(clock, sleep, async_sleep)
        self._gate = KeyGate()
        self._closed = False

    # public -------------------------------------------------------------------------------------------------------
    def call(
        self,
        name: str,
        args: Mapping[str, Any] | None = None,
        *,
        caller: Caller | None = None,
        token: str | None = None,
        timeout_s: float | None = None,
        call_id: str | None = None,
        idempotency_key: str | None = None,
    ) -> ToolResult:
        """Run a tool and wait for its result. ``timeout_s`` bounds the whole call, retries included (each
        attempt is also bounded by the tool's own ``timeout_s``); ``token`` is a scope token to verify.
        ``idempotency_key`` names the action (the same on a re-run): it is recorded, handed to the tool in its
        :class:`ToolContext`, and for a side-effect tool a recorded ok call with it is replayed, not run again;
        a second call with the key waits while the first runs (at most until its own deadline)."""
        call = self._start(name, args, caller, token, timeout_s, call_id, idempotency_key)
        try:
            refused = self._admit(call)
            if refused is None and self._keyed(call):
                refused = self._hold_key(call)
            if refused is None:
                refused = self._guard(call)
            if refused is not None:
                return refused
            try:
                value = self._runner.run_sync(call)
            except KeyboardInterrupt:
                raise
            except BaseException as exc:  # a tool's SystemExit too: a result, never the agent's end
                return self._failed(call, exc)
            return self._succeeded(call, value)
        except Exception as exc:  # a bug of ours: still a result
            return self._internal_error(call, exc)
        finally:
            self._settle(call)

    async def acall(
        self,
        name: str,
        args: Mapping[str, Any] | None = None,
        *,
        caller: Caller | None = None,
        token: str | None = None,
        timeout_s: float | None = None,
        call_id: str | None = None,
        idempotency_key: str | None = None,
    ) -> ToolResult:
        """:meth:`call` for callers on an event loop: async tools run on that loop, sync tools on worker threads."""
        call = self._start(name, args, caller, token, timeout_s, call_id, idempotency_key)
        try:
            refused = self._admit(call)
            if refused is None and self._keyed(call):
                refused = await self._ahold_key(call)
            if refused is None:
                refused = self._guard(call)
            if refused is not None:
                return refused
            try:
                value = await self._runner.run_async(call)
            except asyncio.CancelledError as exc:
                task = asyncio.current_task()
                if task is not None and task.cancelling():
                    raise  # the caller cancelled this call
                return self._failed(call, exc)  # the tool raised it: its failure, not a cancellation
            except KeyboardInterrupt:
                raise
            except BaseException as exc:
                return self._failed(call, exc)
            return self._succeeded(call, value)
        except asyncio.CancelledError:
            self._finish(call, "error", error="cancelled by the caller")
            raise
        except Exception as exc:
            return self._internal_error(call, exc)
        finally:
            self._settle(call)

    def dispatcher(self, caller: Caller | None = None) -> Callable[[str, dict[str, Any], float | None], ToolResult]:
        """The ``dispatch(tool, args, timeout_s)`` callable a compiled mission calls every action through."""

        def dispatch(tool: str, args: dict[str, Any], timeout_s: float | None) -> ToolResult:
            return self.call(tool, args, caller=caller, timeout_s=timeout_s)

        return dispatch

    def close(self) -> None:
        """Stop the worker threads; close the audit log if the executor made it (a log given to it stays open).
        Later calls return an error result."""
        self._closed = True
        self._runner.close()
        if self._owns_audit:
            self.audit.close()

    def __enter__(self) -> ToolExecutor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # stages before the tool runs -----------------------------------------------------------------------------------
    def _start(
        self,
        name: str,
        args: Mapping[str, Any] | None,
        caller: Caller | None,
        token: str | None,
        timeout_s: float | None,
        call_id: str | None,
        idempotency_key: str | None,
    ) -> CallState:
        deadline = None if timeout_s is None else self.clock() + timeout_s
        call = CallState(str(name), {} if args is None else args, call_id or os.urandom(8).hex(), deadline)
        call.caller = caller if caller is not None else self.default_caller
        call.token = token
        call.key = idempotency_key
        return call

    def _admit(self, call: CallState) -> ToolResult | None:
        """Lookup to authorization: a finished result when the call stops there, else None."""
        if self._closed:
            call.stage("lookup", "failed", "closed")
            return self._finish(call, "error", error="the tool executor is closed")
        registry = self.registry
        entry = registry.entry(call.name) or registry.entry(registry.resolve(call.name))
        if entry is None:
            call.stage("lookup", "failed")
            closest = registry.closest(call.name)
            hint = f"; did you mean {', '.join(repr(c) for c in closest)}?" if closest else ""
            return self._finish(call, "error", error=f"unknown tool {call.name!r}{hint}")
        spec = entry.spec
        call.entry, call.name = entry, spec.name
        if spec.available is not None and not is_available(spec):
            call.stage("lookup", "failed", "unavailable")
            return self._finish(call, "error", error=f"tool {spec.name!r} is not available now")
        call.stage("lookup", "passed")

        if not isinstance(call.args, Mapping):
            call.stage("validate_args", "failed")
            return self._finish(call, "error", error=f"invalid arguments: expected an object, got {call.args!r}")
        call.args = dict(call.args)
        detail = argument_errors(entry, call.args)
        if detail is not None:
            call.stage("validate_args", "failed", detail)
            return self._finish(call, "error", error=f"invalid arguments: {detail}")
        if call.key is not None:
            problem = key_problem(call.key)
            if problem is not None:
                call.key = None  # not a key: not recorded as one
                call.stage("validate_args", "failed", problem)
                return self._finish(call, "error", error=f"invalid call: {problem}")
        call.stage("validate_args", "passed")

        denial = self._authenticate(call)
        if denial is None:
            missing = call.caller.missing(spec.scopes)
            denial = f"{call.caller.id!r} lacks scope {', '.join(missing)}" if missing else None
        if denial is not None:
            call.stage("authorize", "failed", denial)
            return self._finish(call, "denied", error=denial)
        call.stage("authorize", "passed")
        return None

    def _guard(self, call: CallState) -> ToolResult | None:
        """Rate limit to breaker: a finished result when the call stops before the tool runs, else None."""
        entry = call.entry
        assert entry is not None
        spec = entry.spec
        if entry.limiter is not None:
            admitted, wait = entry.limiter.acquire(call.caller.id)
            if not admitted:
                call.stage("rate_limit", "failed", f"retry in {wait:.3g} s")
                return self._finish(call, "rate_limited", error=f"rate limit reached for {spec.name}", retry=wait)
            call.stage("rate_limit", "passed")

        if entry.cache is not None:
            hit, cached = entry.cache.get(call.args)
            if hit:
                call.stage("cache", "hit")
                value, report = cached
                return self._finish(call, "ok", output=copy.deepcopy(value), cached=True, injection=report)
            call.stage("cache", "miss")

        allowed, wait, call.is_probe = entry.breaker.admit()
        if not allowed:
            call.stage("circuit_breaker", "failed", f"open; a probe in {wait:.3g} s")
            return self._finish(call, "circuit_open", error=f"{spec.name} is failing; circuit open", retry=wait)
        call.awaits_verdict = True
        call.stage("circuit_breaker", "passed")
        return None

    # the idempotency key ---------------------------------------------------------------------------------------------
    def _keyed(self, call: CallState) -> bool:
        """Whether the call's key guards it: a side-effect tool called with a key."""
        return call.key is not None and call.entry is not None and call.entry.spec.side_effects

    def _hold_key(self, call: CallState) -> ToolResult | None:
        """Take the call's key (waiting while another call with it runs), then replay a recorded ok result."""
        assert call.key is not None
        return self._replay(call, self._gate.hold((call.name, call.key), lambda: self._remaining(call)))

    async def _ahold_key(self, call: CallState) -> ToolResult | None:
        assert call.key is not None
        return self._replay(call, await self._gate.ahold((call.name, call.key), lambda: self._remaining(call)))

    def _remaining(self, call: CallState) -> float | None:
        return None if call.deadline is None else call.deadline - self.clock()

    def _replay(self, call: CallState, held: tuple[GateKey, Flight] | None) -> ToolResult | None:
        """The recorded result of the key's ok call, without running the tool; None when there is none (the tool
        runs, holding the key). ``held`` is None when another call with the key ran past this one's deadline."""
        assert call.key is not None
        if held is None:
            call.stage("idempotency", "failed", "a call with this key is still running")
            return self._finish(
                call,
                "timeout",
                error=f"a call with idempotency key {call.key!r} was still running at this call's deadline; "
                "the tool was not run again",
            )
        call.flight = held
        try:
            found = self.audit.find(call.key, call.name)
        except Exception as exc:  # unknown is not "never ran": refuse rather than risk acting twice
            call.stage("idempotency", "failed", _describe(exc))
            return self._finish(
                call,
                "error",
                error=f"cannot look up idempotency key {call.key!r} in the audit log ({_describe(exc)}); "
                "the tool was not run, so it cannot act twice",
            )
        if found is None:
            call.stage("idempotency", "miss")
            return None
        if not completes(found):
            call.stage("idempotency", "miss", f"call {found.call_id} with this key ended {found.status}: runs again")
            return None
        detail = f"replayed call {found.call_id} of {found.time}"
        if not found.output_kept:
            detail += f"; its output was not kept (over {KEPT_OUTPUT_LIMIT_BYTES} bytes, or not recorded)"
        call.stage("idempotency", "hit", detail)
        output = copy.deepcopy(found.output)
        report = scan_value(output, threshold=self.injection_threshold)
        flagged = report if report.flagged else None
        if flagged is not None and self.on_injection == "withhold":
            return self._finish(call, "error", error="output withheld: it looks like instructions", injection=flagged)
        return self._finish(call, "ok", output=output, injection=flagged, replay_of=found.call_id)

    def _authenticate(self, call: CallState) -> str | None:
        """Why a call's token is refused, or None (no token, or a valid one: then it names the caller)."""
        if call.token is None:
            return None
        if self.authority is None:
            call.caller = unverified_caller(call.token)
            return "a token was given, but this executor has no token authority to verify it"
        try:
            call.caller = self.authority.verify(call.token)
        except InvalidToken as exc:
            call.caller = unverified_caller(call.token)  # recorded as whom it claims to be, never as the default
            return str(exc)
        return None

    # after the tool ran -------------------------------------------------------------------------------------------
    def _verdict(self, call: CallState, healthy: bool | None) -> None:
        """Tell the breaker how the call went (None: it says nothing of the tool's health)."""
        assert call.entry is not None
        call.awaits_verdict = False
        breaker = call.entry.breaker
        if healthy is None:
            breaker.release(probe=call.is_probe)
        elif healthy:
            breaker.success()
        else:
            breaker.failure()

    def _settle(self, call: CallState) -> None:
        if call.awaits_verdict and call.entry is not None:
            self._verdict(call, None)
        if call.flight is not None:  # after the call's record is written: a waiter finds it
            gate_key, flight = call.flight
            call.flight = None
            self._gate.release(gate_key, flight)

    def _failed(self, call: CallState, exc: BaseException) -> ToolResult:
        never_ran = isinstance(exc, DeadlinePassed) and call.attempts == 0
        self._verdict(call, None if never_ran else isinstance(exc, ToolError))
        timed_out = isinstance(exc, TimeoutError)
        call.stage("invoke", "failed", f"{call.attempts} attempt{'s' if call.attempts != 1 else ''}")
        status: ToolStatus = "timeout" if timed_out else "error"
        return self._finish(call, status, error=str(exc) if timed_out and str(exc) else _describe(exc))

    def _succeeded(self, call: CallState, value: Any) -> ToolResult:
        entry = call.entry
        assert entry is not None
        call.stage("invoke", "passed", None if call.attempts == 1 else f"{call.attempts} attempts")
        try:
            refusal = measure(value, self.max_output_bytes).problem
            if refusal is not None:
                raise ToolError(f"the output of {call.name!r} is {refusal}")
            if entry.spec.convert_output is not None:
                value = entry.spec.convert_output(value)
            elif entry.output_validator is not None:
                problem = next(iter(entry.output_validator.iter_errors(value)), None)
                if problem is not None:
                    raise ToolError(
                        f"the tool's output does not match its schema: {problem.json_path}: {problem.message}"
                    )
        except Exception as exc:
            self._verdict(call, False)
            message = str(exc) if isinstance(exc, ToolError) else f"the tool's output is not valid: {_describe(exc)}"
            call.stage("validate_output", "failed", message)
            return self._finish(call, "error", error=message)
        self._verdict(call, True)
        call.stage("validate_output", "passed")
        report = scan_value(value, threshold=self.injection_threshold)
        flagged = report if report.flagged else None
        if flagged is not None:
            call.stage("injection_guard", "flagged", f"score {report.score}")
            if self.on_injection == "withhold":
                return self._finish(
                    call, "error", error="output withheld: it looks like instructions", injection=report
                )
        else:
            call.stage("injection_guard", "passed")
        if entry.cache is not None:
            entry.cache.put(call.args, (copy.deepcopy(value), flagged))
        return self._finish(call, "ok", output=value, injection=flagged)

    def _finish(
        self,
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
            self.audit.write(record)
            call.stage("audit", "passed")
        except Exception as exc:
            call.stage("audit", "failed", _describe(exc))
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

    def _internal_error(self, call: CallState, exc: Exception) -> ToolResult:
        error = f"internal error in the tool executor: {_describe(exc)}"
        try:
            return self._finish(call, "error", error=error)
        except Exception:
            return ToolResult(
                status="error", error=error, latency_s=0.0, attempts=call.attempts, call_id=call.call_id, tool=call.name
            )
