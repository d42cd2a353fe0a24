"""One JSON POST to a model server, the way both wire formats need it: httpx with connect and read timeouts, one
connection pool per event loop (and one for synchronous callers, who send from their own thread), retries with
tenacity on 429, 5xx and failed connections (what Retry-After or retry-after-ms says, else a jittered doubling
backoff), error answers read in OpenAI's and Ollama's shapes, the server's own time when it says it
(``openai-processing-ms``), and the API key kept out of every message.
"""

from __future__ import annotations

import asyncio
import functools
import json
import logging
import math
import random
import ssl
import threading
import time
import weakref
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from email.utils import parsedate_to_datetime
from typing import Any
from urllib.parse import quote

import httpx
import tenacity
from pydantic import SecretStr

from agentic_core.contracts.errors import AgenticUAVError

from .config import RetryPolicy
from .result import LLMStatus

logger = logging.getLogger("agentic_core.reasoning.llm")
EXCERPT_CHARS = 300
REDACTED = "[redacted]"
PROCESSING_HEADER = "openai-processing-ms"
"""OpenAI's answer header: the milliseconds the server spent on the request (llama-cpp-python's server sends it
too)."""
SleepFn = Callable[[float], Awaitable[None]]


class RequestFailure(AgenticUAVError):
    """A request that failed: the status the call's result gets, a message already free of the key, and whether
    sending it again may help."""

    def __init__(
        self,
        status: LLMStatus,
        message: str,
        *,
        http_status: int | None = None,
        retry_after_s: float | None = None,
        retryable: bool = False,
    ) -> None:
        super().__init__(message)
        self.status: LLMStatus = status
        self.message = message
        self.http_status = http_status
        self.retry_after_s = retry_after_s
        self.retryable = retryable


def parse_retry_after(headers: httpx.Headers, now: Callable[[], float] = time.time) -> float | None:
    """Seconds to wait from ``retry-after-ms`` or ``Retry-After`` (seconds or an HTTP date); None when absent.

    >>> parse_retry_after(httpx.Headers({"Retry-After": "2"}))
    2.0
    >>> parse_retry_after(httpx.Headers({"retry-after-ms": "250", "Retry-After": "1"}))
    0.25
    """
    millis = headers.get("retry-after-ms")
    if millis is not None:
        try:
            return max(0.0, float(millis) / 1000)
        except ValueError:
            pass
    value = headers.get("retry-after")
    if value is None:
        return None
    try:
        return max(0.0, float(value))
    except ValueError:
        pass
    try:
        return max(0.0, parsedate_to_datetime(value).timestamp() - now())
    except (TypeError, ValueError, IndexError):
        return None


def describe(exc: BaseException) -> str:
    text = str(exc)
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def error_detail(response: httpx.Response) -> tuple[str, str | None]:
    """``(message, code)`` of an error answer: OpenAI's ``{"error": {"message", "type", "code"}}``, Ollama's
    ``{"error": "..."}``, or an excerpt of whatever else came."""
    try:
        data = response.json()
    except ValueError:
        return (response.text.strip()[:EXCERPT_CHARS] or response.reason_phrase), None
    error = data.get("error") if isinstance(data, dict) else None
    if isinstance(error, str):
        return error, None
    if isinstance(error, dict):
        code = error.get("code")
        tags = ", ".join(str(t) for t in (error.get("type"), code) if t)
        message = str(error.get("message") or "no message")
        return (f"{message} ({tags})" if tags else message), (str(code) if code else None)
    return json.dumps(data, ensure_ascii=False)[:EXCERPT_CHARS], None


class Redactor:
    """Removes a secret from text, as written or as URLs, JSON and reprs quote it.

    >>> Redactor(SecretStr("sk-abc123")).redact("Incorrect API key provided: sk-abc123")
    'Incorrect API key provided: [redacted]'
    """

    def __init__(self, secret: SecretStr | None) -> None:
        value = secret.get_secret_value() if secret is not None else ""
        forms = {value, quote(value, safe=""), json.dumps(value)[1:-1], repr(value)[1:-1]} if len(value) >= 4 else set()
        self._forms = sorted(forms, key=len, reverse=True)

    def redact(self, text: str) -> str:
        for form in self._forms:
            text = text.replace(form, REDACTED)
        return text


@functools.cache
def _ssl_context(trust_env: bool) -> ssl.SSLContext:
    """The TLS context every client shares (httpx builds one per client otherwise, loading the CA bundle each
    time); with ``trust_env`` it honours ``SSL_CERT_FILE`` and ``SSL_CERT_DIR`` as httpx does."""
    return httpx.create_ssl_context(trust_env=trust_env)


@dataclass(frozen=True)
class Answer:
    """A 2xx answer: its JSON object, and the seconds the server says it spent on it (None when it does not say)."""

    data: dict[str, Any]
    server_s: float | None = None


def processing_s(headers: httpx.Headers) -> float | None:
    """The server's own time from ``openai-processing-ms``, in seconds; None when absent or not a number.

    >>> processing_s(httpx.Headers({"openai-processing-ms": "812"}))
    0.812
    """
    value = headers.get(PROCESSING_HEADER)
    if value is None:
        return None
    try:
        seconds = float(value) / 1000
    except ValueError:
        return None
    return seconds if math.isfinite(seconds) and seconds >= 0 else None


def blocking(sleep: SleepFn) -> Callable[[float], None]:
    """The wait between retries for synchronous calls: ``time.sleep`` for ``asyncio.sleep``, else the given (async)
    sleep run to its end, on a thread of its own when this one already runs an event loop."""
    if sleep is asyncio.sleep:
        return time.sleep

    def wait(seconds: float) -> None:
        async def waited() -> None:
            await sleep(seconds)

        try:
            asyncio.get_running_loop()
        except RuntimeError:
            asyncio.run(waited())
            return
        thread = threading.Thread(target=asyncio.run, args=(waited(),), name="llm-retry-wait")
        thread.start()
        thread.join()

    return wait


class JSONEndpoint:
    """POSTs JSON to one URL and returns the JSON object answered, or raises :class:`RequestFailure` when the
    retries are over. ``label`` names the caller in log lines (provider and model).

    :meth:`post` sends from the running event loop; :meth:`post_sync` from the calling thread, with no event loop
    and no hand-over to another thread (the agent's graph calls the model from synchronous code, on the way from
    a critical frame to its alert). Both follow the same retry policy and give the same answers and failures.
    ``transport`` (tests) must serve the kind of call made: ``httpx.MockTransport`` serves both.
    """

    def __init__(
        self,
        url: str,
        *,
        api_key: SecretStr | None,
        timeout: httpx.Timeout,
        retry: RetryPolicy,
        transport: httpx.AsyncBaseTransport | httpx.BaseTransport | None = None,
        trust_env: bool = True,
        sleep: SleepFn = asyncio.sleep,
        label: str = "llm",
    ) -> None:
        self.url = url
        self.server = str(httpx.URL(url).copy_with(path="/", query=None, fragment=None)).rstrip("/")
        self.timeout = timeout
        self.retry = retry
        self.label = label
        self._api_key = api_key
        self._redactor = Redactor(api_key)
        self._transport = transport
        self._trust_env = trust_env
        self._sleep = sleep
        self._sleep_sync = blocking(sleep)
        self._by_loop: weakref.WeakKeyDictionary[asyncio.AbstractEventLoop, httpx.AsyncClient] = (
            weakref.WeakKeyDictionary()
        )
        self._sync: httpx.Client | None = None
        self._sync_lock = threading.Lock()
        self._verify = _ssl_context(trust_env)  # made now, not on the first call (tens of ms)

    @property
    def sends_sync(self) -> bool:
        """Whether :meth:`post_sync` can be used: always, unless the transport given serves only async calls."""
        return self._transport is None or isinstance(self._transport, httpx.BaseTransport)

    def redact(self, text: str) -> str:
        return self._redactor.redact(text)

    async def post(self, body: dict[str, Any], on_attempt: Callable[[], None] = lambda: None) -> Answer:
        """Send ``body`` until an answer comes or the retry policy gives up; ``on_attempt`` runs before each."""

        async def attempt() -> Answer:
            on_attempt()
            try:
                response = await self._client().post(self.url, json=body, headers=self._headers())
            except httpx.TransportError as exc:
                raise self._transport_failure(exc) from None
            return self._answer(response)

        answer: Answer = await tenacity.AsyncRetrying(sleep=self._sleep, **self._retrying())(attempt)
        return answer

    def post_sync(self, body: dict[str, Any], on_attempt: Callable[[], None] = lambda: None) -> Answer:
        """:meth:`post` from the calling thread."""

        def attempt() -> Answer:
            on_attempt()
            try:
                response = self._client_sync().post(self.url, json=body, headers=self._headers())
            except httpx.TransportError as exc:
                raise self._transport_failure(exc) from None
            return self._answer(response)

        answer: Answer = tenacity.Retrying(sleep=self._sleep_sync, **self._retrying())(attempt)
        return answer

    def _retrying(self) -> dict[str, Any]:
        """The retry policy as tenacity's options (all but the sleep, which differs for async and sync calls)."""
        policy = self.retry

        def failure_of(state: tenacity.RetryCallState) -> RequestFailure | None:
            exc = state.outcome.exception() if state.outcome is not None else None
            return exc if isinstance(exc, RequestFailure) else None

        def stop(state: tenacity.RetryCallState) -> bool:
            failure = failure_of(state)
            too_long = failure is not None and (failure.retry_after_s or 0.0) > policy.max_retry_after_s
            return state.attempt_number >= policy.attempts or too_long

        def wait(state: tenacity.RetryCallState) -> float:
            failure = failure_of(state)
            if failure is not None and failure.retry_after_s is not None:
                return failure.retry_after_s
            delay = policy.initial_s * 2.0 ** (state.attempt_number - 1) + random.uniform(0, policy.jitter_s)
            return min(policy.max_s, delay)

        def before_sleep(state: tenacity.RetryCallState) -> None:
            failure = failure_of(state)
            logger.info(
                "%s: %s; retrying in %.2f s (request %d of %d)",
                self.label,
                failure.message if failure is not None else "failed",
                state.upcoming_sleep or 0.0,
                state.attempt_number,
                policy.attempts,
            )

        return {
            "stop": stop,
            "wait": wait,
            "retry": tenacity.retry_if_exception(lambda exc: isinstance(exc, RequestFailure) and exc.retryable),
            "before_sleep": before_sleep,
            "reraise": True,
        }

    def _transport_failure(self, exc: httpx.TransportError) -> RequestFailure:
        """A request that got no answer: no connection, no answer in time, or the connection failed."""
        where = self.server
        if isinstance(exc, httpx.ConnectTimeout):
            message = f"no connection to {where} in {self.timeout.connect:g} s"
            return RequestFailure("timeout", message, retryable=True)
        if isinstance(exc, httpx.TimeoutException):
            message = f"no answer from {where} in {self.timeout.read:g} s ({type(exc).__name__})"
            return RequestFailure("timeout", message, retryable=self.retry.retry_timeouts)
        if isinstance(exc, httpx.ConnectError):
            return RequestFailure("connection", self.redact(f"cannot connect to {where}: {exc}"), retryable=True)
        message = self.redact(f"the connection to {where} failed: {describe(exc)}")
        return RequestFailure("connection", message, retryable=True)

    def _answer(self, response: httpx.Response) -> Answer:
        """The JSON object of a 2xx answer, else the failure it is."""
        where = self.server
        status = response.status_code
        if status >= 400:
            raise self._http_failure(response)
        try:
            data = response.json()
        except ValueError:
            excerpt = self.redact(response.text[:EXCERPT_CHARS])
            raise RequestFailure(
                "http_error", f"the answer from {where} is not JSON: {excerpt!r}", http_status=status
            ) from None
        if not isinstance(data, dict):
            raise RequestFailure("http_error", f"the answer from {where} is not a JSON object", http_status=status)
        return Answer(data, processing_s(response.headers))

    def _http_failure(self, response: httpx.Response) -> RequestFailure:
        status = response.status_code
        message, code = error_detail(response)
        retryable = status in (408, 429) or status >= 500
        if code in ("insufficient_quota", "billing_hard_limit_reached"):
            retryable = False  # waiting does not buy credit
        text = self.redact(f"HTTP {status} from {self.server}: {message}")
        retry_after = parse_retry_after(response.headers) if retryable else None
        kind: LLMStatus = "rate_limited" if status == 429 else "http_error"
        return RequestFailure(kind, text, http_status=status, retry_after_s=retry_after, retryable=retryable)

    def _headers(self) -> dict[str, str]:
        headers = {"Accept": "application/json"}
        if self._api_key is not None and self._api_key.get_secret_value():
            headers["Authorization"] = f"Bearer {self._api_key.get_secret_value()}"
        return headers

    def _client(self) -> httpx.AsyncClient:
        """The httpx client of the running event loop (a connection pool belongs to one loop)."""
        loop = asyncio.get_running_loop()
        client = self._by_loop.get(loop)
        if client is None or client.is_closed:
            transport = self._transport
            if transport is not None and not isinstance(transport, httpx.AsyncBaseTransport):
                raise TypeError("this client's transport serves synchronous calls only: use chat_sync")
            client = httpx.AsyncClient(
                timeout=self.timeout, transport=transport, trust_env=self._trust_env, verify=self._verify
            )
            self._by_loop[loop] = client
        return client

    def _client_sync(self) -> httpx.Client:
        """The httpx client of synchronous calls, shared by every thread (its connection pool is thread-safe)."""
        with self._sync_lock:
            if self._sync is None or self._sync.is_closed:
                transport = self._transport
                if transport is not None and not isinstance(transport, httpx.BaseTransport):
                    raise TypeError("this client's transport serves async calls only")  # chat_sync hands them over
                self._sync = httpx.Client(
                    timeout=self.timeout, transport=transport, trust_env=self._trust_env, verify=self._verify
                )
            return self._sync

    async def probe(self, url: str) -> str | None:
        """GET ``url`` once, with the endpoint's key and timeouts, opening the connection the calls will reuse; None
        when the server answered 2xx, else why not (the key redacted)."""
        try:
            response = await self._client().get(url, headers=self._headers())
        except httpx.HTTPError as exc:
            return self._unreachable(exc)
        return self._probed(response)

    def probe_sync(self, url: str) -> str | None:
        """:meth:`probe` from the calling thread, opening the connection :meth:`post_sync` will reuse."""
        try:
            response = self._client_sync().get(url, headers=self._headers())
        except httpx.HTTPError as exc:
            return self._unreachable(exc)
        return self._probed(response)

    def _unreachable(self, exc: httpx.HTTPError) -> str:
        return self.redact(f"cannot reach {self.server}: {describe(exc)}")

    def _probed(self, response: httpx.Response) -> str | None:
        if response.is_success:
            return None
        message, _ = error_detail(response)
        return self.redact(f"{self.server} answered {response.status_code}: {message}")

    async def aclose(self) -> None:
        """Close the connections opened on the running event loop."""
        client = self._by_loop.pop(asyncio.get_running_loop(), None)
        if client is not None:
            await client.aclose()

    def close_sync(self) -> None:
        """Close the connections of synchronous calls."""
        with self._sync_lock:
            client, self._sync = self._sync, None
        if client is not None:
            client.close()
