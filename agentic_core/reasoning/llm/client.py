"""The LLM client interface and what both wire formats share around the HTTP requests of
:mod:`~agentic_core.reasoning.llm.transport`: tool calls checked against the tools' schemas and shown back to the
model once when they are broken, refusals, per-call and running token and latency accounting, and synchronous
calls made on the caller's own thread.

A call is written once, as an exchange that yields the bodies to send and receives the answers
(:meth:`HTTPChatClient._exchange`); :meth:`~HTTPChatClient.chat` sends them from an event loop and
:meth:`~HTTPChatClient.chat_sync` from the calling thread, so both behave alike to the byte.

Nothing raises across :meth:`HTTPChatClient.chat`: every outcome is an :class:`LLMResult` (but a cancellation by
the caller, which goes on).
"""

from __future__ import annotations

import asyncio
import hashlib
import json
import logging
import threading
import time
from collections.abc import Coroutine, Generator
from dataclasses import dataclass, field
from typing import Any, ClassVar, Protocol, Self, TypeVar, runtime_checkable

import httpx
import jsonschema
from pydantic import BaseModel, SecretStr

from .config import LLMConfig, RetryPolicy
from .messages import ChatRequest, Message, ResponseSchema, ToolCall
from .result import LLMResult, Usage, UsageTotals
from .transport import EXCERPT_CHARS, Answer, JSONEndpoint, RequestFailure, SleepFn, describe

logger = logging.getLogger("agentic_core.reasoning.llm")
T = TypeVar("T")


@runtime_checkable
class LLMClient(Protocol):
    """What a reasoner needs of a model: ``await client.chat(request)`` → :class:`LLMResult`, never an exception.
    Tests and the rule baseline can supply any object with these members."""

    @property
    def provider(self) -> str: ...

    @property
    def model(self) -> str: ...

    async def chat(self, request: ChatRequest) -> LLMResult: ...


def synthesize_call_id(position: int, index: int, name: str, arguments: Any) -> str:
    """An id for a tool call that came without one (Ollama's): the same call at the same place in the same chat
    always gets the same id, so a replayed or resumed run matches its tool results up again.

    >>> synthesize_call_id(3, 0, "flight__land", {}) == synthesize_call_id(3, 0, "flight__land", {})
    True
    >>> synthesize_call_id(3, 0, "flight__land", {}) == synthesize_call_id(3, 1, "flight__land", {})
    False
    """
    text = json.dumps([position, index, name, arguments], sort_keys=True, ensure_ascii=False, default=str)
    return f"call_{hashlib.sha256(text.encode()).hexdigest()[:16]}"


@dataclass
class Turn:
    """One reply of the model, decoded from either wire format (internal to the clients)."""

    content: str | None
    tool_calls: list[ToolCall]
    finish_reason: str | None
    usage: Usage
    model: str | None = None
    refusal: str | None = None
    problems: dict[str, str] = field(default_factory=dict)  # call id -> what is wrong with it
    server_s: float | None = None  # the server's own time, when its reply says it (Ollama's total_duration)


@dataclass
class _Progress:
    """What a call has used so far, across retries and a repair round."""

    attempts: int = 0
    usage: Usage = field(default_factory=Usage)
    model: str | None = None
    server_s: float | None = None

    def count(self) -> None:
        self.attempts += 1


class HTTPChatClient:
    """The shared part of :class:`OpenAICompatibleClient` and :class:`OllamaClient`; see those for examples.

    ``transport`` replaces httpx's network transport (tests); ``sleep`` replaces the wait between retries;
    ``repair_attempts`` is how many times a broken tool call is shown back to the model before the call fails.
    Use it as ``async with`` (or ``with`` for :meth:`chat_sync`), or call :meth:`aclose` / :meth:`close`.
    """

    endpoint: ClassVar[str] = ""
    probe_endpoint: ClassVar[str] = ""
    """A cheap GET under ``base_url`` that a live server answers (its model list), for :meth:`warm`."""
    wire_format: ClassVar[str] = ""
    default_provider: ClassVar[str] = ""

    def __init__(
        self,
        model: str,
        base_url: str,
        *,
        api_key: str | SecretStr | None = None,
        provider: str | None = None,
        connect_timeout_s: float = 5.0,
        read_timeout_s: float = 120.0,
        retry: RetryPolicy | None = None,
        repair_attempts: int = 1,
        transport: httpx.AsyncBaseTransport | httpx.BaseTransport | None = None,
        trust_env: bool = True,
        sleep: SleepFn = asyncio.sleep,
    ) -> None:
        self._model = model
        self.base_url = base_url.rstrip("/")
        self._provider = provider or self.default_provider
        self.repair_attempts = repair_attempts
        secret = api_key if isinstance(api_key, SecretStr) or api_key is None else SecretStr(api_key)
        self._endpoint = JSONEndpoint(
            self.base_url + self.endpoint,
            api_key=secret,
            timeout=httpx.Timeout(connect=connect_timeout_s, read=read_timeout_s, write=read_timeout_s, pool=5.0),
            retry=retry or RetryPolicy(),
            transport=transport,
            trust_env=trust_env,
            sleep=sleep,
            label=f"{self._provider} {model}",
        )
        self._validators: dict[str, jsonschema.protocols.Validator | None] = {}
        self._totals = UsageTotals()
        self._lock = threading.Lock()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._loop_thread: threading.Thread | None = None

    @classmethod
    def from_config(cls, config: LLMConfig, **options: Any) -> Self:
        """A client for a parsed ``--llm`` config; ``options`` override the constructor's keywords."""
        settings: dict[str, Any] = {
            "api_key": config.api_key,
            "provider": config.provider,
            "connect_timeout_s": config.connect_timeout_s,
            "read_timeout_s": config.read_timeout_s,
            "retry": config.retry,
            **cls._config_options(config),
        }
        settings.update(options)
        return cls(config.model, config.base_url, **settings)

    @classmethod
    def _config_options(cls, config: LLMConfig) -> dict[str, Any]:
        return {}

    @property
    def provider(self) -> str:
        return self._provider

    @property
    def model(self) -> str:
        return self._model

    @property
    def retry(self) -> RetryPolicy:
        return self._endpoint.retry

    @property
    def timeout(self) -> httpx.Timeout:
        return self._endpoint.timeout

    @property
    def totals(self) -> UsageTotals:
        """Calls, failures, tokens, HTTP requests and seconds since the client was made (or reset)."""
        with self._lock:
            return self._totals

    def reset_totals(self) -> UsageTotals:
        """Start the running account again; returns the account so far."""
        with self._lock:
            totals, self._totals = self._totals, UsageTotals()
        return totals

    def __repr__(self) -> str:
        return f"{type(self).__name__}(provider={self.provider!r}, model={self.model!r}, base_url={self.base_url!r})"

    # the wire format, written by each subclass --------------------------------------------------------------------
    def request_body(self, request: ChatRequest) -> dict[str, Any]:
        """The JSON body this client sends for ``request``."""
        raise NotImplementedError

    def read_reply(self, data: dict[str, Any], request: ChatRequest) -> Turn:
        """The model's reply in a 2xx answer; raises KeyError, TypeError or ValueError when it is not one."""
        raise NotImplementedError

    # chat ---------------------------------------------------------------------------------------------------------
    async def chat(self, request: ChatRequest) -> LLMResult:
        """Send ``request`` and return the model's reply, or what went wrong, as an :class:`LLMResult`."""
        started, progress = time.perf_counter(), _Progress()
        exchange = self._exchange(request, progress)
        try:
            body = next(exchange)
            while True:
                answer = await self._endpoint.post(body, progress.count)
                try:
                    body = exchange.send(answer)
                except StopIteration as done:  # the exchange's own end, not a StopIteration from below
                    result: LLMResult = done.value
                    break
        except Exception as exc:
            result = self._failed(progress, exc)
        finally:
            exchange.close()
        return self._settled(result, started)

    def chat_sync(self, request: ChatRequest) -> LLMResult:
        """:meth:`chat` for synchronous callers, sent from the calling thread (from the client's own event loop
        thread when a test's transport serves only async calls)."""
        if not self._endpoint.sends_sync:
            return self._run_sync(self.chat(request))
        started, progress = time.perf_counter(), _Progress()
        exchange = self._exchange(request, progress)
        try:
            body = next(exchange)
            while True:
                answer = self._endpoint.post_sync(body, progress.count)
                try:
                    body = exchange.send(answer)
                except StopIteration as done:  # the exchange's own end, not a StopIteration from below
                    result: LLMResult = done.value
                    break
        except Exception as exc:
            result = self._failed(progress, exc)
        finally:
            exchange.close()
        return self._settled(result, started)

    async def chat_structured(
        self,
        request: ChatRequest,
        output: type[BaseModel] | dict[str, Any] | ResponseSchema,
        *,
        name: str | None = None,
    ) -> LLMResult:
        """:func:`~agentic_core.reasoning.llm.structured.chat_structured` with this client."""
        from .structured import chat_structured

        return await chat_structured(self, request, output, name=name)

    def chat_structured_sync(
        self,
        request: ChatRequest,
        output: type[BaseModel] | dict[str, Any] | ResponseSchema,
        *,
        name: str | None = None,
    ) -> LLMResult:
        """:meth:`chat_structured` for synchronous callers, sent from the calling thread."""
        from .structured import chat_structured_sync

        return chat_structured_sync(self, request, output, name=name)

    def _exchange(self, request: ChatRequest, progress: _Progress) -> Generator[dict[str, Any], Answer, LLMResult]:
        """One call without its input and output: yields each request body to send, is sent each answer, and
        returns the result (a broken tool call shown back to the model up to ``repair_attempts`` times). A request
        that fails raises :class:`RequestFailure` out of whoever sends."""
        turn = yield from self._turn(request, progress)
        repairs = 0
        for _ in range(self.repair_attempts):
            if not turn.problems or turn.refusal is not None:
                break
            logger.info(
                "%s %s: broken tool call, shown back to the model: %s",
                self.provider,
                self.model,
                self._endpoint.redact("; ".join(turn.problems.values())),
            )
            request = request.with_messages(*self._repair_messages(turn))
            turn = yield from self._turn(request, progress)
            repairs += 1
        common: dict[str, Any] = {
            "content": turn.content,
            "tool_calls": turn.tool_calls,
            "finish_reason": turn.finish_reason,
            "usage": progress.usage,
            "attempts": progress.attempts,
            "model": progress.model or self.model,
            "provider": self.provider,
            "server_s": progress.server_s,
        }
        if turn.refusal is not None:
            return LLMResult(
                status="refusal", error=self._endpoint.redact(f"the model refused: {turn.refusal}"), **common
            )
        if turn.problems:
            problems = "; ".join(turn.problems.values())
            after = f" after {repairs} correction{'s' if repairs > 1 else ''}" if repairs else ""
            error = f"the model's tool calls are broken{after}: {problems}"
            return LLMResult(status="invalid_output", error=self._endpoint.redact(error), **common)
        return LLMResult(status="ok", repaired=repairs > 0, **common)

    def _turn(self, request: ChatRequest, progress: _Progress) -> Generator[dict[str, Any], Answer, Turn]:
        answer = yield self.request_body(request)
        data = answer.data
        try:
            turn = self.read_reply(data, request)
        except (KeyError, TypeError, ValueError, AttributeError, IndexError) as exc:
            excerpt = json.dumps(data, ensure_ascii=False)[:EXCERPT_CHARS]
            raise RequestFailure(
                "http_error", f"the answer is not a {self.wire_format} reply ({describe(exc)}): {excerpt}"
            ) from None
        progress.usage = progress.usage + turn.usage
        progress.model = turn.model or progress.model
        server_s = turn.server_s if turn.server_s is not None else answer.server_s
        if server_s is not None:
            progress.server_s = (progress.server_s or 0.0) + server_s
        self._check_calls(turn, request)
        return turn

    def _check_calls(self, turn: Turn, request: ChatRequest) -> None:
        """Record what is wrong with each tool call: unknown tool, or arguments against the tool's schema."""
        tools = {tool.name: tool for tool in request.tools}
        for call in turn.tool_calls:
            if call.id in turn.problems:
                continue
            tool = tools.get(call.name)
            if tool is None:
                offered = ", ".join(tools) or "none"
                turn.problems[call.id] = f"{call.name}: there is no such tool (tools: {offered})"
                continue
            validator = self._validator(tool.name, tool.parameters)
            if validator is None:
                continue
            errors = sorted(validator.iter_errors(call.arguments), key=lambda e: str(e.json_path))
            if errors:
                detail = "; ".join(f"{e.json_path}: {e.message}" for e in errors[:3])
                turn.problems[call.id] = f"{call.name}: arguments do not match its schema: {detail}"

    def _validator(self, name: str, schema: dict[str, Any]) -> jsonschema.protocols.Validator | None:
        """The argument validator of a tool, compiled once; None when its schema is not valid JSON Schema (the
        tools executor reports that; here it only means the arguments cannot be checked)."""
        key = json.dumps([name, schema], sort_keys=True, default=str)
        if key not in self._validators:
            try:
                jsonschema.Draft202012Validator.check_schema(schema)
            except jsonschema.SchemaError:
                self._validators[key] = None
            else:
                self._validators[key] = jsonschema.Draft202012Validator(schema)
        return self._validators[key]

    def _repair_messages(self, turn: Turn) -> list[Message]:
        """The broken reply and, for each of its calls, a tool message saying what is wrong (or that it did not run
        because another call in the reply was broken): every call id gets its answer, as OpenAI requires."""
        messages = [Message.assistant(turn.content, turn.tool_calls)]
        for call in turn.tool_calls:
            problem = turn.problems.get(call.id)
            if problem is not None:
                text = f"error, not run: {problem}. Correct the call and make it again."
            else:
                text = "not run: another call in the same reply was broken. Call it again if it is still needed."
            messages.append(Message.tool(call, text))
        return messages

    # results ------------------------------------------------------------------------------------------------------
    def _failed(self, progress: _Progress, exc: Exception) -> LLMResult:
        """The result of a call that raised: a request that failed, or (a bug of ours or of a library) anything."""
        if isinstance(exc, RequestFailure):
            failure = exc
        else:
            logger.error("%s %s: internal error", self.provider, self.model, exc_info=exc)
            failure = RequestFailure("http_error", f"internal error: {describe(exc)}")
        return LLMResult(
            status=failure.status,
            error=self._endpoint.redact(failure.message),
            usage=progress.usage,
            attempts=progress.attempts,
            model=progress.model or self.model,
            provider=self.provider,
            http_status=failure.http_status,
            retry_after_s=failure.retry_after_s if failure.status == "rate_limited" else None,
            server_s=progress.server_s,
        )

    def _settled(self, result: LLMResult, started: float) -> LLMResult:
        """``result`` timed, counted in the running account and logged."""
        result = result.model_copy(update={"latency_s": time.perf_counter() - started})
        with self._lock:
            self._totals = self._totals.add(result)
        self._log(result)
        return result

    def _log(self, result: LLMResult) -> None:
        if result.ok:
            logger.debug(
                "%s %s: ok in %.3f s, %d request(s), %d+%d tokens",
                self.provider,
                result.model,
                result.latency_s,
                result.attempts,
                result.usage.prompt_tokens,
                result.usage.completion_tokens,
            )
        else:
            logger.warning(
                "%s %s: %s in %.3f s, %d request(s): %s",
                self.provider,
                result.model,
                result.status,
                result.latency_s,
                result.attempts,
                result.error,
            )

    # lifecycle ------------------------------------------------------------------------------------------------------
    def warm(self) -> str | None:
        """Get the synchronous calls ready now — the connection to the server, through one GET of the server's
        model list — so the first real call (for the hybrid reasoner, the critical event) pays for none of it, and
        a server that does not answer is known before it is needed. None when the server answered, else why not;
        nothing is raised."""
        url = self.base_url + self.probe_endpoint
        try:
            if self._endpoint.sends_sync:
                return self._endpoint.probe_sync(url)
            return self._run_sync(self._endpoint.probe(url))
        except Exception as exc:  # a probe is advice: it never stops the caller
            return f"{type(exc).__name__}: {exc}"

    def _run_sync(self, coroutine: Coroutine[Any, Any, T]) -> T:
        loop = self._background_loop()
        if threading.current_thread() is self._loop_thread:
            coroutine.close()
            raise RuntimeError("chat_sync was called from the client's own event loop: await chat() there instead")
        return asyncio.run_coroutine_threadsafe(coroutine, loop).result()

    def _background_loop(self) -> asyncio.AbstractEventLoop:
        with self._lock:
            if self._loop is None:
                loop = asyncio.new_event_loop()
                thread = threading.Thread(target=loop.run_forever, name="llm-client-loop", daemon=True)
                thread.start()
                self._loop, self._loop_thread = loop, thread
            return self._loop

    async def aclose(self) -> None:
        """Close the connections this client opened on the running event loop."""
        await self._endpoint.aclose()

    def close(self) -> None:
        """Close the connections of :meth:`chat_sync` (and stop its event loop thread, if it had one)."""
        self._endpoint.close_sync()
        with self._lock:
            loop, thread, self._loop, self._loop_thread = self._loop, self._loop_thread, None, None
        if loop is None or thread is None:
            return
        asyncio.run_coroutine_threadsafe(self.aclose(), loop).result(timeout=10)
        loop.call_soon_threadsafe(loop.stop)
        thread.join(timeout=10)
        loop.close()

    async def __aenter__(self) -> Self:
        return self

    async def __aexit__(self, *exc_info: object) -> None:
        await self.aclose()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
