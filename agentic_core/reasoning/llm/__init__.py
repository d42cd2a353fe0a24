"""LLM clients: one interface over OpenAI-compatible chat completions (OpenAI, vLLM, llama.cpp server, LM Studio,
Ollama's /v1) and Ollama's native /api/chat, chosen by ``--llm`` or ``AGENTIC_UAV_LLM``.

Every call returns an :class:`LLMResult` (``ok``, ``rate_limited``, ``timeout``, ``http_error``,
``invalid_output``, ``refusal``, ``connection``) with the tokens, latency and HTTP requests it took; tool calls
come back as the same :class:`ToolCall` from either server; API keys come from the environment only and never
appear in a result or a log line.

>>> from agentic_core.reasoning.llm import ChatRequest, Message, create_client
>>> client = create_client("ollama:gemma3:4b@http://127.0.0.1:11434", environ={})
>>> request = ChatRequest(messages=[Message.system("You fly a drone."), Message.user("Battery at 12%.")])
>>> [m["role"] for m in client.request_body(request)["messages"]]
['system', 'user']

With a server running, ``result = await client.chat(request)`` (or ``client.chat_sync(request)``), then
``result.ok``, ``result.content``, ``result.tool_calls``, ``result.usage`` and ``client.totals``.
"""

from .client import HTTPChatClient, LLMClient, synthesize_call_id
from .config import LLMConfig, LLMSpecError, RetryPolicy, llm_config, parse_llm_spec
from .factory import create_client
from .messages import ChatRequest, Image, Message, ResponseSchema, ToolCall, ToolDefinition
from .ollama import OllamaClient
from .openai_compat import OpenAICompatibleClient
from .result import LLMResult, LLMStatus, Usage, UsageTotals
from .structured import chat_structured, response_schema, validate_output
from .transport import parse_retry_after

__all__ = [
    "ChatRequest",
    "HTTPChatClient",
    "Image",
    "LLMClient",
    "LLMConfig",
    "LLMResult",
    "LLMSpecError",
    "LLMStatus",
    "Message",
    "OllamaClient",
    "OpenAICompatibleClient",
    "ResponseSchema",
    "RetryPolicy",
    "ToolCall",
    "ToolDefinition",
    "Usage",
    "UsageTotals",
    "chat_structured",
    "create_client",
    "llm_config",
    "parse_llm_spec",
    "parse_retry_after",
    "response_schema",
    "synthesize_call_id",
    "validate_output",
]
