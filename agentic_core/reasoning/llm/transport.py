"""One JSON POST to a model server, the way both wire formats need it: httpx with connect and read timeouts, one
connection pool per event loop, retries with tenacity on 429, 5xx and failed connections (what Retry-After or
retry-after-ms says, else a jittered doubling backoff), error answers read in OpenAI's and Ollama's shapes, and
the API key kept out of every message.
"""

from __future__ import annotations

import asyncio
import functools
import json
import logging
import random
import ssl
import time
import weakref
from collections.abc import Awaitable, Callable
from email.utils import parsedate_to_datetime
from typing import Any
from urllib.parse import quote

import httpx
import tenacity
from pydantic import SecretStr

from .config import RetryPolicy
from .result import LLMStatus

logger = logging.getLogger("agentic_core.reasoning.llm")
EXCERPT_CHARS = 300
REDACTED = "[redacted]"
SleepFn = Callable[[float], Awaitable[None]]


class RequestFailure(Exception):
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


class JSONEndpoint:
    """POSTs JSON to one URL and returns the JSON object answered, or raises :class:`RequestFailure` when the
    retries are over. ``label`` names the caller in log lines (provider and model)."""

    def __init__(
        self,
        url: str,
        *,
        api_key: SecretStr | None,
        timeout: httpx.Timeout,
        retry: RetryPolicy,
        transport: httpx.AsyncBaseTransport | None = None,
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
        self._by_loop: weakref.WeakKeyDictionary[asyncio.AbstractEventLoop, httpx.AsyncClient] = (
            weakref.WeakKeyDictionary()
        )
        self._verify = _ssl_context(trust_env)  # made now, not on the first call (tens of ms)

    def redact(self, text: str) -> str:
        return self._redactor.redact(text)

    async def post(self, body: dict[str, Any], on_attempt: Callable[[], None] = lambda: None) -> dict[str, Any]:
        """Send ``body`` until an answer comes or the retry policy gives up; ``on_attempt`` runs before each."""
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

        async def attempt() -> dict[str, Any]:
            on_attempt()
            return await self._post_once(body)

        retrying = tenacity.AsyncRetrying(
            stop=stop,
            wait=wait,
            retry=tenacity.retry_if_exception(lambda exc: isinstance(exc, RequestFailure) and exc.retryable),
            sleep=self._sleep,
            before_sleep=before_sleep,
            reraise=True,
        )
        answer: dict[str, Any] = await retrying(attempt)
        return answer

    async def _post_once(self, body: dict[str, Any]) -> dict[str, Any]:
        where = self.server
        try:
            response = await self._client().post(self.url, json=body, headers=self._headers())
        except httpx.ConnectTimeout:
            message = f"no connection to {where} in {self.timeout.connect:g} s"
            raise RequestFailure("timeout", message, retryable=True) from None
        except httpx.TimeoutException as exc:
            message = f"no answer from {where} in {self.timeout.read:g} s ({type(exc).__name__})"
            raise RequestFailure("timeout", message, retryable=self.retry.retry_timeouts) from None
        except httpx.ConnectError as exc:
            raise RequestFailure(
                "connection", self.redact(f"cannot connect to {where}: {exc}"), retryable=True
            ) from None
        except httpx.TransportError as exc:
            message = self.redact(f"the connection to {where} failed: {describe(exc)}")
            raise RequestFailure("connection", message, retryable=True) from None
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
        return data

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
            client = httpx.AsyncClient(
                timeout=self.timeout, transport=self._transport, trust_env=self._trust_env, verify=self._verify
            )
            self._by_loop[loop] = client
        return client

    async def probe(self, url: str) -> str | None:
        """GET ``url`` once, with the endpoint's key and timeouts, opening the connection the calls will reuse; None
        when the server answered 2xx, else why not (the key redacted)."""
        try:
            response = await self._client().get(url, headers=self._headers())
        except httpx.HTTPError as exc:
            return self.redact(f"cannot reach {self.server}: {describe(exc)}")
        if response.is_success:
            return None
        message, _ = error_detail(response)
        return self.redact(f"{self.server} answered {response.status_code}: {message}")

    async def aclose(self) -> None:
        """Close the connections opened on the running event loop."""
        client = self._by_loop.pop(asyncio.get_running_loop(), None)
        if client is not None:
            await client.aclose()
