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

The stages before the tool runs (lookup to circuit breaker) are :mod:`tools.admission`'s; every call ends in
:func:`tools.call_end.finish`, which audits it and makes its result.
"""

from __future__ import annotations

import asyncio
import copy
import os
import time
from collections.abc import Awaitable, Callable, Mapping
from typing import Any, Literal

from .admission import admit, guard
from .attempts import AttemptRunner, CallState
from .audit import AuditLog, MemoryAuditLog, completes
from .auth import ANONYMOUS, Caller, TokenAuthority
from .call_end import describe, finish, internal_error
from .errors import DeadlinePassed, ToolError
from .idempotency import KEPT_OUTPUT_LIMIT_BYTES, Flight, GateKey, KeyGate
from .output_size import configured_limit, measure
from .registry import ToolRegistry
from .result import ToolResult, ToolStatus
from .security import DEFAULT_THRESHOLD, scan_value


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
            refused = admit(call, self.registry, self.authority, self.audit, closed=self._closed)
            if refused is None and self._keyed(call):
                refused = self._hold_key(call)
            if refused is None:
                refused = guard(call, self.audit)
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
            return internal_error(self.audit, call, exc)
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
            refused = admit(call, self.registry, self.authority, self.audit, closed=self._closed)
            if refused is None and self._keyed(call):
                refused = await self._ahold_key(call)
            if refused is None:
                refused = guard(call, self.audit)
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
            finish(self.audit, call, "error", error="cancelled by the caller")
            raise
        except Exception as exc:
            return internal_error(self.audit, call, exc)
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

    # the call started (its stages before the tool runs: tools.admission) -----------------------------------------
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
            return finish(
                self.audit,
                call,
                "timeout",
                error=f"a call with idempotency key {call.key!r} was still running at this call's deadline; "
                "the tool was not run again",
            )
        call.flight = held
        try:
            found = self.audit.find(call.key, call.name)
        except Exception as exc:  # unknown is not "never ran": refuse rather than risk acting twice
            call.stage("idempotency", "failed", describe(exc))
            return finish(
                self.audit,
                call,
                "error",
                error=f"cannot look up idempotency key {call.key!r} in the audit log ({describe(exc)}); "
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
            return finish(
                self.audit, call, "error", error="output withheld: it looks like instructions", injection=flagged
            )
        return finish(self.audit, call, "ok", output=output, injection=flagged, replay_of=found.call_id)

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
        return finish(self.audit, call, status, error=str(exc) if timed_out and str(exc) else describe(exc))

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
            message = str(exc) if isinstance(exc, ToolError) else f"the tool's output is not valid: {describe(exc)}"
            call.stage("validate_output", "failed", message)
            return finish(self.audit, call, "error", error=message)
        self._verdict(call, True)
        call.stage("validate_output", "passed")
        report = scan_value(value, threshold=self.injection_threshold)
        flagged = report if report.flagged else None
        if flagged is not None:
            call.stage("injection_guard", "flagged", f"score {report.score}")
            if self.on_injection == "withhold":
                return finish(
                    self.audit, call, "error", error="output withheld: it looks like instructions", injection=report
                )
        else:
            call.stage("injection_guard", "passed")
        if entry.cache is not None:
            entry.cache.put(call.args, (copy.deepcopy(value), flagged))
        return finish(self.audit, call, "ok", output=value, injection=flagged)
