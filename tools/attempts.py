"""Running a tool's attempts: per-attempt timeouts, the call's deadline, retries with jittered exponential backoff
(tenacity) on transient failures only, and the bridges between sync and async code (worker threads, a background
event loop).
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import contextvars
import random
import threading
import time
from collections.abc import Awaitable, Callable
from typing import Any

import tenacity

from .auth import ANONYMOUS, Caller
from .errors import CallTimeout, DeadlinePassed
from .idempotency import Flight, GateKey
from .registry import RegisteredTool
from .result import Stage, StageName, StageOutcome
from .spec import RetrySpec, ToolContext
from .workers import ThreadHandoff


class CallState:
    """One call as it moves through the executor's stages."""

    __slots__ = (
        "args",
        "attempts",
        "awaits_verdict",
        "call_id",
        "caller",
        "deadline",
        "entry",
        "flight",
        "is_probe",
        "key",
        "name",
        "stages",
        "started",
        "token",
    )

    def __init__(self, name: str, args: Any, call_id: str, deadline: float | None) -> None:
        self.name = name
        self.args = args
        self.call_id = call_id
        self.deadline = deadline  # on the executor's clock
        self.started = time.perf_counter()
        self.stages: list[Stage] = []
        self.caller: Caller = ANONYMOUS
        self.entry: RegisteredTool | None = None
        self.attempts = 0
        self.token: str | None = None
        self.awaits_verdict = False  # the breaker let it through and awaits a verdict
        self.is_probe = False  # ... as the half-open probe
        self.key: str | None = None  # the caller's idempotency key
        self.flight: tuple[GateKey, Flight] | None = None  # the key this call holds in the executor's gate

    def stage(self, name: StageName, outcome: StageOutcome, detail: str | None = None) -> None:
        self.stages.append(Stage(name, outcome, detail))


def backoff(policy: RetrySpec) -> Callable[[tenacity.RetryCallState], float]:
    """``initial_s``, doubling after each failure, plus up to ``jitter_s`` of random delay; at most ``max_s``."""

    def wait(state: tenacity.RetryCallState) -> float:
        delay = policy.initial_s * 2.0 ** (state.attempt_number - 1) + random.uniform(0, policy.jitter_s)
        return float(min(policy.max_s, delay))

    return wait


async def bounded(awaitable: Awaitable[Any], timeout: float | None) -> Any:
    """``await awaitable``, cancelled after ``timeout`` seconds (a :class:`CallTimeout`); a TimeoutError the tool
    raises itself passes through as the tool's own."""
    scope = asyncio.timeout(timeout)
    try:
        async with scope:
            return await awaitable
    except TimeoutError:
        if timeout is not None and scope.expired():
            raise CallTimeout(f"no answer in {timeout:.3g} s") from None
        raise


LOOP_GRACE_S = 1.0  # how long past its timeout a sync caller waits for an async tool before it gives up on the loop


def _in_own_thread(fn: Callable[[], Any]) -> asyncio.Future[Any]:
    """``fn()`` on a thread of its own, as a future of the running loop. Not a shared pool: a sync tool that hangs
    past its timeout keeps its thread, and in a pool enough of them would starve every other tool."""
    loop = asyncio.get_running_loop()
    future: asyncio.Future[Any] = loop.create_future()
    run = contextvars.copy_context().run

    def settle(value: Any, error: BaseException | None) -> None:
        if future.done():
            return
        if error is not None:
            future.set_exception(error)
        else:
            future.set_result(value)

    def work() -> None:
        try:
            value, error = run(fn), None
        except BaseException as exc:  # handed to the awaiting call, which turns it into a result
            value, error = None, exc
        with contextlib.suppress(RuntimeError):  # the loop closed meanwhile: nobody waits for this answer any more
            loop.call_soon_threadsafe(settle, value, error)

    threading.Thread(target=work, name="tool-sync-on-loop", daemon=True).start()
    return future


class AttemptRunner:
    """Runs a call's attempts, sync or async, with retries and timeouts; returns the tool's value or raises."""

    def __init__(
        self,
        clock: Callable[[], float],
        sleep: Callable[[float], None],
        async_sleep: Callable[[float], Awaitable[None]],
    ) -> None:
        self.clock = clock
        self.sleep = sleep
        self.async_sleep = async_sleep
        self._handoff = ThreadHandoff()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._loop_thread: threading.Thread | None = None
        self._loop_lock = threading.Lock()
        self._closed = False

    def _begin(self, call: CallState) -> tuple[ToolContext, float | None]:
        """The next attempt's context and timeout; :class:`DeadlinePassed` when no time is left for it."""
        assert call.entry is not None
        limit = call.entry.spec.timeout_s
        if call.deadline is not None:
            remaining = call.deadline - self.clock()
            if remaining <= 0:
                raise DeadlinePassed("the call's deadline passed before the tool could run")
            limit = remaining if limit is None else min(limit, remaining)
        call.attempts += 1
        context = ToolContext(call.call_id, call.entry.spec.name, call.caller, call.attempts, call.deadline, call.key)
        return context, limit

    def _retrying(self, call: CallState, sleep: Callable[[float], Any]) -> dict[str, Any]:
        assert call.entry is not None
        policy = call.entry.spec.retry
        idempotent = call.entry.spec.idempotent

        def retryable(exc: BaseException) -> bool:
            if isinstance(exc, DeadlinePassed) or (isinstance(exc, CallTimeout) and not idempotent):
                return False  # an abandoned attempt of a tool that acts may still act: never start a second
            return policy.retry_if(exc)

        def stop(state: tenacity.RetryCallState) -> bool:
            if state.attempt_number >= policy.attempts:
                return True
            return call.deadline is not None and self.clock() + (state.upcoming_sleep or 0.0) >= call.deadline

        return {
            "stop": stop,
            "wait": backoff(policy),
            "retry": tenacity.retry_if_exception(retryable),
            "sleep": sleep,
            "reraise": True,
        }

    # synchronous callers ------------------------------------------------------------------------------------------
    def _attempt_sync(self, call: CallState) -> Any:
        assert call.entry is not None
        spec = call.entry.spec
        context, timeout = self._begin(call)
        if spec.is_async:
            coroutine = bounded(spec.handler(call.args, context), timeout)
            future = asyncio.run_coroutine_threadsafe(coroutine, self._background_loop())
            try:  # bounded() ends it in time unless the loop itself is blocked (an async tool that never yields)
                return future.result(None if timeout is None else timeout + LOOP_GRACE_S)
            except TimeoutError:  # concurrent.futures.TimeoutError is TimeoutError: the tool's, or the wait's
                if future.done():
                    raise
                future.cancel()
                raise CallTimeout(f"no answer in {timeout:.3g} s (the async tools' event loop is blocked)") from None
            except concurrent.futures.CancelledError:
                raise CallTimeout("the executor was closed while the tool ran") from None
        if timeout is None:
            return spec.handler(call.args, context)  # no timeout to keep: no thread hand-off either
        return self._handoff.run(lambda: spec.handler(call.args, context), timeout)

    def run_sync(self, call: CallState) -> Any:
        assert call.entry is not None
        if call.entry.spec.retry.attempts == 1:
            return self._attempt_sync(call)
        return tenacity.Retrying(**self._retrying(call, self.sleep))(self._attempt_sync, call)

    # callers on an event loop -------------------------------------------------------------------------------------
    async def _attempt_async(self, call: CallState) -> Any:
        assert call.entry is not None
        spec = call.entry.spec
        context, timeout = self._begin(call)
        if spec.is_async:
            return await bounded(spec.handler(call.args, context), timeout)
        return await bounded(_in_own_thread(lambda: spec.handler(call.args, context)), timeout)

    async def run_async(self, call: CallState) -> Any:
        assert call.entry is not None
        if call.entry.spec.retry.attempts == 1:
            return await self._attempt_async(call)
        return await tenacity.AsyncRetrying(**self._retrying(call, self.async_sleep))(self._attempt_async, call)

    def _background_loop(self) -> asyncio.AbstractEventLoop:
        """An event loop on its own thread, for async tools called from synchronous code."""
        with self._loop_lock:
            if self._closed:
                raise RuntimeError("the tool executor is closed")
            if self._loop is None:
                loop = asyncio.new_event_loop()
                self._loop_thread = threading.Thread(target=loop.run_forever, name="tool-async-loop", daemon=True)
                self._loop_thread.start()
                self._loop = loop
            return self._loop

    def close(self) -> None:
        """Stop the worker threads and the background loop (its running tools are cancelled), and close it."""
        self._handoff.close()
        with self._loop_lock:
            self._closed = True
            loop, thread, self._loop, self._loop_thread = self._loop, self._loop_thread, None, None
        if loop is None or thread is None:
            return

        def stop() -> None:
            for task in asyncio.all_tasks(loop):
                task.cancel()
            loop.call_soon(loop.stop)  # after the cancellations have been delivered

        loop.call_soon_threadsafe(stop)
        thread.join(timeout=5)
        if not thread.is_alive():
            loop.close()
