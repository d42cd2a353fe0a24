"""``--llm`` specs and the environment: providers, models with colons, base URLs and their defaults, where the key
comes from, and errors that name the spec and what is wrong with it."""

from __future__ import annotations

import pytest

from agentic_core.reasoning.llm import (
    LLMSpecError,
    OllamaClient,
    OpenAICompatibleClient,
    create_client,
    llm_config,
    parse_llm_spec,
)

KEY = "sk-test-0123456789"


def test_openai() -> None:
    config = parse_llm_spec("openai:gpt-4o", environ={"OPENAI_API_KEY": KEY})
    assert (config.provider, config.model, config.base_url) == ("openai", "gpt-4o", "https://api.openai.com/v1")
    assert config.max_tokens_field == "max_completion_tokens" and config.api_key_env == "OPENAI_API_KEY"


def test_openai_base_url_and_the_project_key_first() -> None:
    env = {"OPENAI_API_KEY": "sk-other", "AGENTIC_UAV_LLM_API_KEY": KEY, "OPENAI_BASE_URL": "https://proxy.example/v1"}
    config = parse_llm_spec("openai:gpt-4o-mini", environ=env)
    assert config.base_url == "https://proxy.example/v1" and config.api_key_env == "AGENTIC_UAV_LLM_API_KEY"
    assert parse_llm_spec("openai:gpt-4o@https://gw.example/v1/", environ=env).base_url == "https://gw.example/v1"


def test_openai_without_a_key() -> None:
    with pytest.raises(LLMSpecError, match=r"^--llm 'openai:gpt-4o': openai needs an API key in OPENAI_API_KEY"):
        parse_llm_spec("openai:gpt-4o", environ={})


def test_ollama_models_keep_their_tags() -> None:
    config = parse_llm_spec("ollama:gemma3:4b@http://host:11434", environ={})
    assert (config.provider, config.model, config.base_url) == ("ollama", "gemma3:4b", "http://host:11434")
    assert config.api_key is None and config.max_tokens_field == "max_tokens"
    assert parse_llm_spec("ollama:library/qwen2.5:7b-instruct-q4_K_M", environ={}).model == (
        "library/qwen2.5:7b-instruct-q4_K_M"
    )


@pytest.mark.parametrize(
    ("host", "base_url"),
    [
        (None, "http://localhost:11434"),
        ("0.0.0.0", "http://0.0.0.0:11434"),
        ("gpu-box:8080", "http://gpu-box:8080"),
        ("https://ollama.example", "https://ollama.example"),
        ("http://10.0.0.5:11434/", "http://10.0.0.5:11434"),
    ],
)
def test_ollama_host(host: str | None, base_url: str) -> None:
    env = {} if host is None else {"OLLAMA_HOST": host}
    assert parse_llm_spec("ollama:gemma3:4b", environ=env).base_url == base_url


def test_ollama_takes_the_server_root() -> None:
    with pytest.raises(LLMSpecError, match=r"not its /v1 route; .* openai-compatible:MODEL@http://host:11434/v1"):
        parse_llm_spec("ollama:gemma3:4b@http://host:11434/v1", environ={})


def test_openai_compatible() -> None:
    env = {"OPENAI_API_KEY": "sk-openai-only"}
    config = parse_llm_spec("openai-compatible:Qwen/Qwen2.5-7B-Instruct@http://gpu:8000", environ=env)
    assert (config.model, config.base_url) == ("Qwen/Qwen2.5-7B-Instruct", "http://gpu:8000/v1")
    assert config.api_key is None  # an OpenAI key is never sent to another server
    keyed = parse_llm_spec("openai-compatible:m@http://gpu:8000/api/v1", environ={"AGENTIC_UAV_LLM_API_KEY": KEY})
    assert keyed.base_url == "http://gpu:8000/api/v1" and keyed.api_key_env == "AGENTIC_UAV_LLM_API_KEY"


@pytest.mark.parametrize(
    ("spec", "problem"),
    [
        ("gpt-4o", "no provider before ':'"),
        ("anthropic:claude", "unknown provider 'anthropic' (known: openai, openai-compatible, ollama)"),
        ("ollama:", "no model name after the provider"),
        ("ollama:@http://h:1", "no model name after the provider"),
        ("openai-compatible:m", "openai-compatible needs its base URL after '@'"),
        ("openai-compatible:m@ftp://h/v1", "the base URL after '@' must start with http:// or https://"),
        ("openai-compatible:m@http://user:pw@h/v1", "put credentials in AGENTIC_UAV_LLM_API_KEY, not in the base URL"),
        ("openai-compatible:m@http://h/v1?x=1", "must not have a query or fragment"),
        ("ollama:gemma 3", "has white space in it"),
    ],
)
def test_bad_specs_say_what_is_wrong(spec: str, problem: str) -> None:
    with pytest.raises(LLMSpecError) as caught:
        parse_llm_spec(spec, environ={})
    message = str(caught.value)
    assert message.startswith(f"--llm {spec!r}: ") and problem in message
    assert "expected PROVIDER:MODEL[@BASE_URL]" in message


def test_the_environment_chooses_when_no_spec_is_given() -> None:
    assert llm_config(environ={"AGENTIC_UAV_LLM": "ollama:gemma3:4b"}).model == "gemma3:4b"
    assert llm_config("ollama:llama3.2", environ={"AGENTIC_UAV_LLM": "ollama:gemma3:4b"}).model == "llama3.2"
    with pytest.raises(LLMSpecError, match=r"^AGENTIC_UAV_LLM 'gemma3': no provider"):
        llm_config(environ={"AGENTIC_UAV_LLM": "gemma3"})
    with pytest.raises(LLMSpecError, match="no LLM chosen: pass --llm"):
        llm_config(environ={})


def test_the_read_timeout_from_the_environment() -> None:
    assert parse_llm_spec("ollama:m", environ={"AGENTIC_UAV_LLM_TIMEOUT_S": "15"}).read_timeout_s == 15.0
    with pytest.raises(LLMSpecError, match="AGENTIC_UAV_LLM_TIMEOUT_S='soon'"):
        parse_llm_spec("ollama:m", environ={"AGENTIC_UAV_LLM_TIMEOUT_S": "soon"})


def test_create_client_picks_the_wire_format() -> None:
    ollama = create_client("ollama:gemma3:4b", environ={"AGENTIC_UAV_LLM_TIMEOUT_S": "7"})
    assert isinstance(ollama, OllamaClient) and ollama.timeout.read == 7.0
    compatible = create_client(environ={"AGENTIC_UAV_LLM": "openai-compatible:m@http://127.0.0.1:1"}, repair_attempts=0)
    assert isinstance(compatible, OpenAICompatibleClient) and compatible.repair_attempts == 0
    assert compatible.base_url == "http://127.0.0.1:1/v1" and compatible.provider == "openai-compatible"
