"""A client for the model ``--llm`` or the environment chose: OpenAI and OpenAI-compatible servers get the chat
completions client, Ollama its native one."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from .client import HTTPChatClient
from .config import LLMConfig, llm_config
from .ollama import OllamaClient
from .openai_compat import OpenAICompatibleClient


def create_client(
    choice: LLMConfig | str | None = None, *, environ: Mapping[str, str] | None = None, **options: Any
) -> HTTPChatClient:
    """The client for a config, a spec such as ``ollama:gemma3:4b``, or (None) the ``AGENTIC_UAV_LLM`` variable;
    ``options`` go to the client (``transport``, ``sleep``, ``repair_attempts``, ...). Raises
    :class:`~agentic_core.reasoning.llm.config.LLMSpecError` for a spec that cannot be used.

    >>> create_client("ollama:gemma3:4b@http://127.0.0.1:11434", environ={})
    OllamaClient(provider='ollama', model='gemma3:4b', base_url='http://127.0.0.1:11434')
    >>> create_client("openai-compatible:qwen2.5@http://127.0.0.1:8000", environ={}).base_url
    'http://127.0.0.1:8000/v1'
    """
    config = choice if isinstance(choice, LLMConfig) else llm_config(choice, environ=environ)
    if config.provider == "ollama":
        return OllamaClient.from_config(config, **options)
    return OpenAICompatibleClient.from_config(config, **options)
