"""A campaign's model calls: recorded for replay, limited per endpoint, counted for the budget.

Every model call of a job goes through a :class:`CampaignChat` that wraps the system's client:

* **Cache.** The answer is kept as a :class:`ResponseEntry`, keyed by the request (provider, model, messages,
  sampling settings, output schema) and numbered by how often this system sent that request in this scene; the
  campaign appends entries to ``model_cache.jsonl``. A replay (``--replay DIR``) answers every call from DIR's
  entries and never opens a connection, so a campaign is re-scored with no model at all. A rate limit, timeout or
  failed connection is not an answer and is not kept.
* **Concurrency per endpoint.** At most ``max_concurrent`` calls in flight to one base URL from one worker
  process. A ``rate_limited`` answer (HTTP 429 after the client's own retries) halves that limit and pauses the
  endpoint (what Retry-After said, at least a backoff that doubles with each rate limit in a row); each run of
  ``limit`` answers in a row raises it by one again, up to ``max_concurrent``. After ``give_up_after``
  rate-limited answers in a row the endpoint is not asked until its pause ends: calls in between fail at once as
  ``rate_limited``, an error record, never a hang.
* **Usage.** Calls and tokens per model, for the campaign's budget (:mod:`evaluation.campaign.budget`).

>>> limiter = EndpointLimiter(4, clock=iter([0.0, 0.0, 0.0, 10.0]).__next__)
>>> limiter.release(rate_limited=True, retry_after_s=None); limiter.limit
2
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import threading
import time
from collections import Counter
from collections.abc import Callable, Iterator
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from agentic_core.reasoning.llm import ChatRequest, LLMResult, create_client
from agentic_core.reasoning.llm.result import Usage

from .systems import SystemSpec

NOT_ANSWERS = frozenset({"rate_limited", "timeout", "connection"})
"""Statuses that say nothing about the model's answer: never cached."""


class ModelSettings(BaseModel):
    """How a campaign's workers call models (``--max-concurrent``; the rest for tests and tuning)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    max_concurrent: int = Field(default=4, ge=1, le=256, description="calls in flight per endpoint and worker")
    backoff_initial_s: float = Field(default=1.0, ge=0.0)
    backoff_max_s: float = Field(default=60.0, ge=0.0)
    give_up_after: int = Field(default=5, ge=1, description="rate-limited answers in a row before failing fast")


class ResponseEntry(BaseModel):
    """One model answer as the cache keeps it (a line of ``model_cache.jsonl``)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    scene_id: str
    system: str
    key: str = Field(description="SHA-256 of the request (see request_key)")
    n: int = Field(ge=0, description="the how-manieth time this system sent this request in this scene")
    result: dict[str, Any] = Field(description="the LLMResult as JSON data")


class ModelUsage(BaseModel):
    """Calls and tokens of one model in one job."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    model: str
    calls: int = 0
    prompt_tokens: int = 0
    completion_tokens: int = 0


def request_key(provider: str, model: str, request: ChatRequest, output: Any) -> str:
    """SHA-256 of what decides a model's answer: provider, model, the request and the output schema."""
    schema = output.model_json_schema() if isinstance(output, type) and issubclass(output, BaseModel) else output
    text = json.dumps(
        {"provider": provider, "model": model, "request": request.model_dump(mode="json"), "output": schema},
        sort_keys=True,
        separators=(",", ":"),
        default=str,
    )
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


class EndpointLimiter:
    """The concurrency limit of one endpoint in this process: halved on a rate limit, raised again by one after
    ``limit`` answers in a row, never above ``cap`` (see the module docs)."""

    def __init__(
        self,
        cap: int,
        *,
        backoff_initial_s: float = 1.0,
        backoff_max_s: float = 60.0,
        give_up_after: int = 5,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.cap = cap
        self.limit = cap
        self.in_flight = 0
        self.backoff_initial_s = backoff_initial_s
        self.backoff_max_s = backoff_max_s
        self.give_up_after = give_up_after
        self.clock = clock
        self.strikes = 0
        self.resume_at = 0.0
        self._backoff = backoff_initial_s
        self._answers = 0
        self._cond = threading.Condition()

    def acquire(self) -> bool:
        """Wait for a place (and for the endpoint's pause to end); ``False`` when the endpoint is given up on
        until its pause ends (the caller fails the call at once)."""
        with self._cond:
            while True:
                wait = self.resume_at - self.clock()
                if self.strikes >= self.give_up_after and wait > 0:
                    return False
                if wait <= 0 and self.in_flight < self.limit:
                    self.in_flight += 1
                    return True
                self._cond.wait(timeout=wait if wait > 0 else None)

    def release(self, *, rate_limited: bool, retry_after_s: float | None, acquired: bool = True) -> None:
        """One call ended: ``rate_limited`` halves the limit and pauses the endpoint; an answer counts toward
        raising it again."""
        with self._cond:
            if acquired:
                self.in_flight = max(0, self.in_flight - 1)
            if rate_limited:
                self.limit = max(1, self.limit // 2)
                self.strikes += 1
                self._answers = 0
                pause = max(retry_after_s or 0.0, self._backoff)  # "Retry-After: 0" from a server still refusing
                self._backoff = min(self.backoff_max_s, max(self._backoff * 2.0, 1e-3))
                self.resume_at = max(self.resume_at, self.clock() + pause)
            else:
                self.strikes = 0
                self._backoff = self.backoff_initial_s
                self._answers += 1
                if self._answers >= self.limit and self.limit < self.cap:
                    self.limit += 1
                    self._answers = 0
            self._cond.notify_all()


_LIMITERS: dict[str, EndpointLimiter] = {}
_LIMITERS_LOCK = threading.Lock()


def limiter_for(endpoint: str, settings: ModelSettings) -> EndpointLimiter:
    """This process's limiter of ``endpoint`` (one per endpoint, shared by every job the process runs)."""
    with _LIMITERS_LOCK:
        found = _LIMITERS.get(endpoint)
        if found is None or found.cap != settings.max_concurrent:
            found = _LIMITERS[endpoint] = EndpointLimiter(
                settings.max_concurrent,
                backoff_initial_s=settings.backoff_initial_s,
                backoff_max_s=settings.backoff_max_s,
                give_up_after=settings.give_up_after,
            )
        return found


class CampaignChat:
    """A system's model client as a campaign uses it: through the cache (or only from it, in a replay), the
    endpoint's limiter, and the job's usage count."""

    def __init__(self, session: ModelSession, system: SystemSpec) -> None:
        assert system.llm is not None
        self.session = session
        self.system = system
        self._client = None if session.replay is not None else create_client(system.llm)
        if self._client is not None:
            self.provider, self._model, self.endpoint = self._client.provider, self._client.model, self._client.base_url
        else:  # a replay needs neither a server nor a key: the spec is the normalised provider:model@base_url
            self.provider, _, rest = system.llm.partition(":")
            self._model, self.endpoint = rest.rsplit("@", 1) if "@" in rest else (rest, "")
        self._sent: Counter[str] = Counter()

    @property
    def model(self) -> str:
        return self._model

    def chat_structured_sync(self, request: ChatRequest, output: Any, *, name: str | None = None) -> LLMResult:
        key = request_key(self.provider, self._model, request, output)
        n = self._sent[key]
        self._sent[key] += 1
        if self._client is None:
            return self.session.replayed(self.system.name, key, n, output, self._model, self.provider)
        limiter = limiter_for(self.endpoint, self.session.settings)
        if not limiter.acquire():
            return LLMResult(
                status="rate_limited",
                error=f"{self.endpoint} answered 429 {limiter.strikes} times in a row; not asked until its pause ends",
                model=self._model,
                provider=self.provider,
            )
        result: LLMResult | None = None
        try:
            result = self._client.chat_structured_sync(request, output, name=name)
        finally:
            limited = result is not None and result.status == "rate_limited"
            limiter.release(rate_limited=limited, retry_after_s=result.retry_after_s if result else None)
        self.session.kept(self.system.name, self._model, key, n, result)
        return result

    def close(self) -> None:
        if self._client is not None:
            self._client.close()


class ModelSession:
    """The model calls of one job: the clients it made, the responses it received, and what they cost."""

    def __init__(self, scene_id: str, settings: ModelSettings, replay: list[ResponseEntry] | None) -> None:
        self.scene_id = scene_id
        self.settings = settings
        self.replay = None if replay is None else {(e.system, e.key, e.n): e.result for e in replay}
        self.responses: list[ResponseEntry] = []
        self._usage: dict[str, Usage] = {}
        self._calls: Counter[str] = Counter()
        self._lock = threading.Lock()

    def client_for(self, system: SystemSpec) -> CampaignChat:
        """The client of an ``llm`` or ``hybrid`` system for this job."""
        return CampaignChat(self, system)

    def kept(self, system: str, model: str, key: str, n: int, result: LLMResult) -> None:
        """Count a call's usage under the model asked for (the name ``--price`` uses) and keep its answer."""
        with self._lock:
            self._calls[model] += 1
            self._usage[model] = self._usage.get(model, Usage()) + result.usage
            if result.status not in NOT_ANSWERS:
                data = result.model_dump(mode="json")
                self.responses.append(ResponseEntry(scene_id=self.scene_id, system=system, key=key, n=n, result=data))

    def replayed(self, system: str, key: str, n: int, output: Any, model: str, provider: str) -> LLMResult:
        assert self.replay is not None
        data = self.replay.get((system, key, n))
        if data is None:
            return LLMResult(
                status="connection",
                error="not in the response cache (a replay asks no model)",
                model=model,
                provider=provider,
            )
        with self._lock:  # kept in the new campaign's cache too, so a replay can be replayed
            self.responses.append(ResponseEntry(scene_id=self.scene_id, system=system, key=key, n=n, result=data))
        result = LLMResult.model_validate(data)
        if result.parsed is not None and isinstance(output, type) and issubclass(output, BaseModel):
            result = result.model_copy(update={"parsed": output.model_validate(result.parsed)})
        return result

    def usage(self) -> list[ModelUsage]:
        return [
            ModelUsage(
                model=m, calls=self._calls[m], prompt_tokens=u.prompt_tokens, completion_tokens=u.completion_tokens
            )
            for m, u in sorted(self._usage.items())
        ]


@contextlib.contextmanager
def model_session(
    scene_id: str, settings: ModelSettings, replay: list[ResponseEntry] | None = None
) -> Iterator[ModelSession]:
    """A job's :class:`ModelSession` (see the module docs)."""
    yield ModelSession(scene_id, settings, replay)


__all__ = [
    "CampaignChat",
    "EndpointLimiter",
    "ModelSession",
    "ModelSettings",
    "ModelUsage",
    "ResponseEntry",
    "limiter_for",
    "model_session",
    "request_key",
]
