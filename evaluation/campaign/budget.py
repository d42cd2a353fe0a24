"""A campaign's spending limit: model calls, tokens and money, counted after each job.

``--budget-calls N``, ``--budget-tokens N`` and ``--budget-usd X`` (with ``--price MODEL=IN/OUT``, US dollars per
million prompt and completion tokens) stop a campaign once what its jobs have spent reaches a limit: no job is
started after that, the jobs already running finish and are kept, and the campaign exits 3 saying what was spent.
Run the same command with a larger budget to go on from there. The limit is checked between jobs, so the spend may
pass it by what the jobs in flight cost (one job when running in this process).

>>> budget = Budget(calls=10, prices={"gpt-4o": parse_price("gpt-4o=2.5/10")[1]})
>>> spend = Spend()
>>> spend.add([ModelUsage(model="gpt-4o", calls=12, prompt_tokens=1_000_000, completion_tokens=0)], budget)
>>> spend.usd, spend.exceeded(budget)
(2.5, 'model calls: 12 of 10')
"""

from __future__ import annotations

import re
from collections.abc import Iterable

from pydantic import BaseModel, ConfigDict, Field

from agentic_core.contracts.errors import InputError

from .model_calls import ModelUsage

_PRICE = re.compile(r"^(?P<model>[^=\s]+)=(?P<prompt>\d+(?:\.\d+)?)/(?P<completion>\d+(?:\.\d+)?)$")


class Price(BaseModel):
    """What one model costs, in US dollars per million tokens."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    prompt_per_mtok: float = Field(ge=0.0)
    completion_per_mtok: float = Field(ge=0.0)


class Budget(BaseModel):
    """The limits (``None``: no limit) and the prices the money limit is counted with."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    calls: int | None = Field(default=None, ge=1)
    tokens: int | None = Field(default=None, ge=1)
    usd: float | None = Field(default=None, gt=0.0)
    prices: dict[str, Price] = Field(default_factory=dict)

    @property
    def limited(self) -> bool:
        return any(v is not None for v in (self.calls, self.tokens, self.usd))


def parse_price(text: str) -> tuple[str, Price]:
    """``MODEL=IN/OUT`` (dollars per million prompt / completion tokens) → (model, price); InputError else."""
    match = _PRICE.match(text.strip())
    if match is None:
        raise InputError(
            f"--price {text!r}: expected MODEL=IN/OUT in US dollars per million tokens, e.g. gpt-4o=2.5/10"
        )
    prompt, completion = float(match.group("prompt")), float(match.group("completion"))
    return match.group("model"), Price(prompt_per_mtok=prompt, completion_per_mtok=completion)


class Spend:
    """What a campaign's jobs have spent so far in this run."""

    def __init__(self) -> None:
        self.calls = 0
        self.tokens = 0
        self.usd = 0.0

    def add(self, usage: Iterable[ModelUsage], budget: Budget) -> None:
        for u in usage:
            self.calls += u.calls
            self.tokens += u.prompt_tokens + u.completion_tokens
            price = budget.prices.get(u.model)
            if price is not None:
                self.usd += (
                    u.prompt_tokens * price.prompt_per_mtok + u.completion_tokens * price.completion_per_mtok
                ) / 1e6

    def exceeded(self, budget: Budget) -> str | None:
        """Which limit the spend has reached, said with its numbers; ``None`` while within every limit."""
        if budget.calls is not None and self.calls >= budget.calls:
            return f"model calls: {self.calls} of {budget.calls}"
        if budget.tokens is not None and self.tokens >= budget.tokens:
            return f"tokens: {self.tokens} of {budget.tokens}"
        if budget.usd is not None and self.usd >= budget.usd:
            return f"cost: ${self.usd:.4f} of ${budget.usd:g}"
        return None

    def text(self) -> str:
        return f"{self.calls} model calls, {self.tokens} tokens, ${self.usd:.4f}"


__all__ = ["Budget", "Price", "Spend", "parse_price"]
