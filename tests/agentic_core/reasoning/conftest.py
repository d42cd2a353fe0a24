"""The stand-in model server (OpenAI's wire format on 127.0.0.1) and a client of it, for the reasoner tests."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from agentic_core.reasoning.llm import OpenAICompatibleClient, RetryPolicy

from .llm.standin import StandIn


@pytest.fixture
def standin() -> Iterator[StandIn]:
    with StandIn() as server:
        yield server


@pytest.fixture
def client(standin: StandIn) -> Iterator[OpenAICompatibleClient]:
    async def no_wait(seconds: float) -> None:
        return None

    made = OpenAICompatibleClient(
        "gpt-4o", standin.url + "/v1", api_key="sk-test", trust_env=False, sleep=no_wait,
        retry=RetryPolicy(attempts=2, initial_s=0.1, max_s=0.1, jitter_s=0),
    )  # fmt: skip
    with made:
        yield made
