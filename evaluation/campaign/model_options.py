"""``eval campaign``'s options for model calls: the concurrency cap, the budget, the prices and the replay."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

from agentic_core.contracts.errors import InputError

from .budget import Budget, Price, parse_price
from .model_calls import ModelSettings
from .systems import SystemSpec


def add_model_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the model-call options to ``parser``."""
    group = parser.add_argument_group("model calls")
    group.add_argument(
        "--max-concurrent", type=int, default=4, metavar="N",
        help="calls in flight per model endpoint and worker; halved on HTTP 429, raised again as answers come (4)",
    )  # fmt: skip
    group.add_argument("--budget-calls", type=int, metavar="N", help="stop once N model calls are spent")
    group.add_argument("--budget-tokens", type=int, metavar="N", help="stop once N tokens are spent")
    group.add_argument("--budget-usd", type=float, metavar="X", help="stop once X US dollars are spent (--price)")
    group.add_argument(
        "--price", action="append", default=[], metavar="MODEL=IN/OUT",
        help="a model's price in US dollars per million prompt/completion tokens (repeatable)",
    )  # fmt: skip
    group.add_argument(
        "--replay", type=Path, metavar="DIR",
        help="answer every model call from DIR's model_cache.jsonl (no model server), to re-score a campaign",
    )  # fmt: skip


def model_options(args: argparse.Namespace, systems: Sequence[SystemSpec]) -> tuple[ModelSettings, Budget]:
    """The model settings and the budget the options ask for; InputError naming the option when one is wrong."""
    if not 1 <= args.max_concurrent <= 256:
        raise InputError(f"--max-concurrent must be 1 to 256, got {args.max_concurrent}")
    for name in ("budget_calls", "budget_tokens"):
        value = getattr(args, name)
        if value is not None and value < 1:
            raise InputError(f"--{name.replace('_', '-')} must be at least 1, got {value}")
    if args.budget_usd is not None and not args.budget_usd > 0:
        raise InputError(f"--budget-usd must be above 0, got {args.budget_usd:g}")
    prices: dict[str, Price] = dict(parse_price(text) for text in args.price)
    if args.budget_usd is not None:
        models = {_model(s) for s in systems if s.llm}
        unpriced = sorted(m for m in models if m not in prices)
        if unpriced:
            raise InputError(f"--budget-usd needs a --price for every model; none for: {', '.join(unpriced)}")
    if args.replay is not None and not args.replay.is_dir():
        raise InputError(f"--replay {args.replay}: not a campaign directory")
    budget = Budget(calls=args.budget_calls, tokens=args.budget_tokens, usd=args.budget_usd, prices=prices)
    return ModelSettings(max_concurrent=args.max_concurrent), budget


def _model(system: SystemSpec) -> str:
    """The model name of a normalised ``provider:model@base_url`` spec."""
    rest = (system.llm or "").partition(":")[2]
    return rest.rsplit("@", 1)[0] if "@" in rest else rest


__all__ = ["add_model_arguments", "model_options"]
