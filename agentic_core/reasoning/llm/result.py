"""What a chat call returns, whatever happened: a failing model, server or link is a result the agent sees, never
an exception across the client's boundary (as :class:`tools.ToolResult` is for tools).
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from .messages import Message, ToolCall

LLMStatus = Literal["ok", "rate_limited", "timeout", "http_error", "invalid_output", "refusal", "connection"]
"""``ok``; ``rate_limited`` (429 after the retries, or a Retry-After too long to wait); ``timeout`` (no
connection or no answer in time); ``http_error`` (an error status, or an answer that is not the API's format);
``invalid_output`` (the model's reply broke JSON or a schema, still after it was shown the problem once);
``refusal`` (the model declined, or a content filter stopped it); ``connection`` (refused, reset, DNS)."""


class Usage(BaseModel):
    """Tokens a call used, as the server counted them (0 when it did not say)."""

    model_config = ConfigDict(frozen=True)

    prompt_tokens: int = Field(default=0, ge=0)
    completion_tokens: int = Field(default=0, ge=0)

    @property
    def total_tokens(self) -> int:
        return self.prompt_tokens + self.completion_tokens

    def __add__(self, other: Usage) -> Usage:
        return Usage(
            prompt_tokens=self.prompt_tokens + other.prompt_tokens,
            completion_tokens=self.completion_tokens + other.completion_tokens,
        )


class LLMResult(BaseModel):
    """The outcome of one chat call, its retries and any repair round included.

    >>> result = LLMResult(status="ok", content="No one is there.", model="gemma3:4b", provider="ollama",
    ...     latency_s=0.8, attempts=1, usage=Usage(prompt_tokens=40, completion_tokens=5))
    >>> result.ok, result.usage.total_tokens
    (True, 45)
    >>> result.assistant_message().content
    'No one is there.'
    """

    model_config = ConfigDict(frozen=True)

    status: LLMStatus
    content: str | None = Field(default=None, description="the model's text (None when it only called tools)")
    tool_calls: list[ToolCall] = Field(default_factory=list)
    parsed: Any = Field(default=None, description="structured output, validated: a model instance or JSON value")
    error: str | None = Field(default=None, description="what went wrong, for the agent and the operator")
    finish_reason: str | None = Field(default=None, description="as the server said it (finish or done reason)")
    usage: Usage = Field(default_factory=Usage)
    latency_s: float = Field(default=0.0, ge=0, description="wall time of the call, retries and repair included")
    server_s: float | None = Field(
        default=None,
        ge=0,
        description="of latency_s, the time the server says it spent (OpenAI's openai-processing-ms header, "
        "Ollama's total_duration), summed over the requests that said it; None when none did",
    )
    attempts: int = Field(default=0, ge=0, description="HTTP requests sent, retries and repair included")
    model: str = Field(description="the model that answered, as the server named it (else the one asked for)")
    provider: str
    http_status: int | None = None
    retry_after_s: float | None = Field(default=None, description="for rate_limited: when the server allows more")
    repaired: bool = Field(default=False, description="the model was shown a problem with its reply and fixed it")

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def assistant_message(self) -> Message:
        """The model's reply as a message, to append to the chat before the tool results."""
        return Message.assistant(self.content if self.content is not None or self.tool_calls else "", self.tool_calls)


class UsageTotals(BaseModel):
    """A client's running account: calls, failures, tokens, HTTP requests and time, since it was made or reset."""

    model_config = ConfigDict(frozen=True)

    calls: int = 0
    failures: int = 0
    prompt_tokens: int = 0
    completion_tokens: int = 0
    attempts: int = 0
    latency_s: float = 0.0

    @property
    def total_tokens(self) -> int:
        return self.prompt_tokens + self.completion_tokens

    def add(self, result: LLMResult) -> UsageTotals:
        return UsageTotals(
            calls=self.calls + 1,
            failures=self.failures + (0 if result.ok else 1),
            prompt_tokens=self.prompt_tokens + result.usage.prompt_tokens,
            completion_tokens=self.completion_tokens + result.usage.completion_tokens,
            attempts=self.attempts + result.attempts,
            latency_s=self.latency_s + result.latency_s,
        )
