"""Fixed data for the statistics tests, and helpers to hand the same data to pingouin (dev extra)."""

from __future__ import annotations

import importlib
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np
import pytest

from evaluation.stats.parametric import Moments
from evaluation.stats.pvalues import PValue

TOL = 1e-9


def close(a: float | None, b: float, tol: float = TOL) -> bool:
    """|a - b| <= tol * max(1, |b|): 1e-9 absolute for p-values, relative for large statistics."""
    assert a is not None
    return abs(a - b) <= tol * max(1.0, abs(b))


def pval(p: PValue | None) -> PValue:
    assert p is not None
    return p


def pv(p: PValue | None) -> float:
    return pval(p).value


def num(x: float | None) -> float:
    assert x is not None
    return x


@pytest.fixture(scope="session")
def groups3() -> dict[str, np.ndarray]:
    """Three unequal, unequal-variance groups with ties (rounded to 2 decimals)."""
    rng = np.random.default_rng(20240601)
    return {
        "a": np.round(rng.normal(10.0, 1.0, 17), 2),
        "b": np.round(rng.normal(11.0, 2.5, 23), 2),
        "c": np.round(rng.gamma(4.0, 2.5, 12), 2),
    }


@pytest.fixture(scope="session")
def moments3(groups3: dict[str, np.ndarray]) -> list[Moments]:
    return [Moments.of(k, v) for k, v in groups3.items()]


def frame(groups: dict[str, np.ndarray]) -> Any:
    """The groups as a long pandas DataFrame (columns g, x) for pingouin."""
    pd: Any = importlib.import_module("pandas")
    labels: Sequence[str] = [k for k, v in groups.items() for _ in range(len(v))]
    return pd.DataFrame({"g": labels, "x": np.concatenate(list(groups.values()))})


@pytest.fixture(scope="session")
def pg() -> Any:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return pytest.importorskip("pingouin")


@pytest.fixture
def clean_env(monkeypatch: pytest.MonkeyPatch) -> None:
    """No model or proxy settings from the environment reach a campaign under test."""
    for name in ("AGENTIC_UAV_LLM", "AGENTIC_UAV_LLM_API_KEY", "OPENAI_API_KEY", "HTTP_PROXY", "HTTPS_PROXY"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("NO_PROXY", "127.0.0.1")
