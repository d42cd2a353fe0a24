"""Fixtures shared by the graph tests: both checkpointers, so every persistence rule is checked on each."""

from collections.abc import Iterator
from pathlib import Path

import pytest

from agentic_core.graph import BaseCheckpointSaver, InMemorySaver, SqliteSaver


@pytest.fixture(params=["memory", "sqlite"])
def saver(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[BaseCheckpointSaver]:
    if request.param == "memory":
        yield InMemorySaver()
    else:
        s = SqliteSaver(tmp_path / "checkpoints.sqlite")
        yield s
        s.close()
