"""The reasoning layer (ARCHITECTURE.md): the ReAct agent graph, the reasoners and the LLM clients they call
(:mod:`agentic_core.reasoning.llm`: one interface over OpenAI-compatible servers and Ollama)."""
