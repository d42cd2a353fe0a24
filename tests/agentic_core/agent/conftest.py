"""Every test here has a time limit: ``timeout`` is registered here so the marker works with or without the
pytest-timeout plugin (which enforces it when installed); every wait in these tests is bounded besides."""

from __future__ import annotations

import pytest


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "timeout(seconds): fail the test when it runs longer (pytest-timeout)")
