"""The campaign's errors: one that cannot start or go on, and one stopped by its budget."""

from __future__ import annotations

from agentic_core.contracts.errors import AgenticUAVError


class CampaignError(AgenticUAVError):
    """A campaign that cannot start or go on; ``usage`` errors (exit 2) are the caller's to fix."""

    def __init__(self, message: str, *, usage: bool = True) -> None:
        super().__init__(message)
        self.usage = usage
        self.exit_status = 2 if usage else 1


class BudgetSpent(CampaignError):
    """The campaign stopped because its budget is spent; what finished is kept (exit 3: run again with a larger
    budget to go on)."""

    def __init__(self, message: str) -> None:
        super().__init__(message, usage=False)
        self.exit_status = 3


__all__ = ["BudgetSpent", "CampaignError"]
