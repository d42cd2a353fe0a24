"""Which model to talk to: ``--llm`` specs such as ``openai:gpt-4o``, ``ollama:gemma3:4b@http://host:11434`` or
``openai-compatible:MODEL@BASE_URL``, read into a config with the API key taken from the environment only.

The key comes from ``AGENTIC_UAV_LLM_API_KEY`` (any provider), else ``OPENAI_API_KEY`` for ``openai:`` alone: an
OpenAI key is never sent to another server. It is held as a ``SecretStr`` and never appears in a repr or a log.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Literal

import httpx
from pydantic import BaseModel, ConfigDict, Field, SecretStr

from agentic_core.contracts.errors import InputError

Provider = Literal["openai", "openai-compatible", "ollama"]
PROVIDERS: tuple[Provider, ...] = ("openai", "openai-compatible", "ollama")
SPEC_ENV = "AGENTIC_UAV_LLM"
KEY_ENV = "AGENTIC_UAV_LLM_API_KEY"
TIMEOUT_ENV = "AGENTIC_UAV_LLM_TIMEOUT_S"
OPENAI_KEY_ENV = "OPENAI_API_KEY"
OPENAI_BASE_ENV = "OPENAI_BASE_URL"
OLLAMA_HOST_ENV = "OLLAMA_HOST"
OPENAI_BASE_URL = "https://api.openai.com/v1"
OLLAMA_BASE_URL = "http://localhost:11434"
EXAMPLES = "openai:gpt-4o, ollama:gemma3:4b@http://localhost:11434 or openai-compatible:MODEL@http://localhost:8000/v1"


class LLMSpecError(InputError):
    """A ``--llm`` spec or LLM environment setting that cannot be used; the message names it and what is wrong."""


class RetryPolicy(BaseModel):
    """When to send a request again: on 429, 5xx and failed connections (and timeouts if ``retry_timeouts``),
    up to ``attempts`` requests in all, waiting what Retry-After says or else a jittered doubling backoff.

    A Retry-After longer than ``max_retry_after_s`` is not waited out: the call returns ``rate_limited`` with
    ``retry_after_s`` set, for the agent to decide (a drone should not hang a minute on a busy API).

    >>> RetryPolicy().attempts
    3
    """

    model_config = ConfigDict(frozen=True)

    attempts: int = Field(default=3, ge=1, le=10)
    initial_s: float = Field(default=0.5, ge=0)
    max_s: float = Field(default=8.0, ge=0)
    jitter_s: float = Field(default=0.25, ge=0)
    max_retry_after_s: float = Field(default=30.0, ge=0)
    retry_timeouts: bool = Field(default=False, description="also retry a request that got no answer in time")


class LLMConfig(BaseModel):
    """A chosen model: provider, model name, server and credential, timeouts and retries.

    >>> config = LLMConfig(provider="ollama", model="gemma3:4b", base_url="http://localhost:11434")
    >>> config.spec()
    'ollama:gemma3:4b@http://localhost:11434'
    """

    model_config = ConfigDict(frozen=True)

    provider: Provider
    model: str = Field(min_length=1)
    base_url: str
    api_key: SecretStr | None = None
    api_key_env: str | None = Field(default=None, description="the environment variable the key came from")
    connect_timeout_s: float = Field(default=5.0, gt=0)
    read_timeout_s: float = Field(default=120.0, gt=0, description="a local model's first answer includes loading")
    retry: RetryPolicy = Field(default_factory=RetryPolicy)
    max_tokens_field: Literal["max_tokens", "max_completion_tokens"] = "max_tokens"

    def spec(self) -> str:
        """The spec that selects this model again (never the key)."""
        return f"{self.provider}:{self.model}@{self.base_url}"


def _problem(spec: str, source: str, problem: str) -> LLMSpecError:
    return LLMSpecError(f"{source} {spec!r}: {problem}; expected PROVIDER:MODEL[@BASE_URL], e.g. {EXAMPLES}")


def _base_url(text: str, spec: str, source: str) -> httpx.URL:
    try:
        url = httpx.URL(text)
    except (httpx.InvalidURL, TypeError) as exc:
        raise _problem(spec, source, f"the base URL {text!r} is not a URL ({exc})") from None
    if url.scheme not in ("http", "https") or not url.host:
        raise _problem(spec, source, f"the base URL {text!r} must start with http:// or https:// and name a host")
    if url.userinfo:
        raise _problem(spec, source, f"put credentials in {KEY_ENV}, not in the base URL")
    if url.query or url.fragment:
        raise _problem(spec, source, f"the base URL {text!r} must not have a query or fragment")
    return url


def _ollama_host(value: str) -> str:
    """``OLLAMA_HOST`` as Ollama reads it: ``host``, ``host:port`` or a URL; http and port 11434 by default."""
    text = value.strip()
    if "://" not in text:
        text = f"http://{text}"
    url = httpx.URL(text)
    if url.port is None and url.scheme == "http":
        url = url.copy_with(port=11434)
    return str(url).rstrip("/")


def parse_llm_spec(spec: str, *, environ: Mapping[str, str] | None = None, source: str = "--llm") -> LLMConfig:
    """A config from ``PROVIDER:MODEL[@BASE_URL]``; ``source`` names where the spec came from in error messages.

    Defaults: ``openai`` uses ``OPENAI_BASE_URL`` or https://api.openai.com/v1 and needs a key; ``ollama`` uses
    ``OLLAMA_HOST`` or http://localhost:11434 (the server root: the native API is at ``/api/chat``);
    ``openai-compatible`` needs its base URL, and a bare ``http://host:port`` gets ``/v1``.

    >>> config = parse_llm_spec("ollama:gemma3:4b@http://10.0.0.5:11434", environ={})
    >>> config.provider, config.model, config.base_url
    ('ollama', 'gemma3:4b', 'http://10.0.0.5:11434')
    >>> parse_llm_spec("openai-compatible:qwen2.5@http://gpu:8000", environ={}).base_url
    'http://gpu:8000/v1'
    >>> parse_llm_spec("openai:gpt-4o", environ={"OPENAI_API_KEY": "sk-test"}).api_key
    SecretStr('**********')
    >>> parse_llm_spec("gpt-4o", environ={})
    Traceback (most recent call last):
    ...
    agentic_core.reasoning.llm.config.LLMSpecError: --llm 'gpt-4o': no provider before ':'; expected ...
    """
    env = os.environ if environ is None else environ
    text = spec.strip()
    provider_text, colon, rest = text.partition(":")
    if not colon:
        raise _problem(spec, source, "no provider before ':'")
    provider = provider_text.strip().lower()
    if provider not in PROVIDERS:
        raise _problem(spec, source, f"unknown provider {provider_text!r} (known: {', '.join(PROVIDERS)})")
    model, url_text = rest, None
    for marker in ("@https://", "@http://"):
        at = rest.rfind(marker)
        if at >= 0:
            model, url_text = rest[:at], rest[at + 1 :]
            break
    if url_text is None and "@" in rest:
        raise _problem(spec, source, "the base URL after '@' must start with http:// or https://")
    model = model.strip()
    if not model:
        raise _problem(spec, source, "no model name after the provider")
    if any(c.isspace() for c in model):
        raise _problem(spec, source, f"the model name {model!r} has white space in it")

    if provider == "openai":
        url = _base_url(url_text or env.get(OPENAI_BASE_ENV) or OPENAI_BASE_URL, spec, source)
    elif provider == "ollama":
        url = _base_url(url_text or _ollama_host(env.get(OLLAMA_HOST_ENV) or OLLAMA_BASE_URL), spec, source)
        if url.path.rstrip("/").endswith("/v1"):
            raise _problem(
                spec,
                source,
                "ollama: takes the server root (http://host:11434), not its /v1 route; for that route use "
                "openai-compatible:MODEL@http://host:11434/v1",
            )
    else:
        if url_text is None:
            raise _problem(spec, source, "openai-compatible needs its base URL after '@'")
        url = _base_url(url_text, spec, source)
        if url.path in ("", "/"):
            url = url.copy_with(path="/v1")

    key_env = KEY_ENV if env.get(KEY_ENV) else None
    if key_env is None and provider == "openai" and env.get(OPENAI_KEY_ENV):
        key_env = OPENAI_KEY_ENV
    if provider == "openai" and key_env is None:
        raise _problem(spec, source, f"openai needs an API key in {OPENAI_KEY_ENV} or {KEY_ENV} (both unset)")
    read_timeout = 120.0
    if env.get(TIMEOUT_ENV):
        try:
            read_timeout = float(env[TIMEOUT_ENV])
        except ValueError:
            read_timeout = -1.0
        if not read_timeout > 0:
            raise LLMSpecError(f"{TIMEOUT_ENV}={env[TIMEOUT_ENV]!r}: expected a number of seconds above 0")
    return LLMConfig(
        provider=provider,
        model=model,
        base_url=str(url).rstrip("/"),
        api_key=SecretStr(env[key_env]) if key_env else None,
        api_key_env=key_env,
        read_timeout_s=read_timeout,
        max_tokens_field="max_completion_tokens" if provider == "openai" else "max_tokens",
    )


def llm_config(spec: str | None = None, *, environ: Mapping[str, str] | None = None) -> LLMConfig:
    """The config for ``--llm SPEC``, or for the ``AGENTIC_UAV_LLM`` environment variable when no spec is given.

    >>> llm_config(environ={"AGENTIC_UAV_LLM": "ollama:gemma3:4b"}).base_url
    'http://localhost:11434'
    """
    env = os.environ if environ is None else environ
    if spec:
        return parse_llm_spec(spec, environ=env)
    from_env = env.get(SPEC_ENV, "").strip()
    if not from_env:
        raise LLMSpecError(f"no LLM chosen: pass --llm PROVIDER:MODEL[@BASE_URL] or set {SPEC_ENV} (e.g. {EXAMPLES})")
    return parse_llm_spec(from_env, environ=env, source=SPEC_ENV)
