"""The injection guard's corpus figures, recorded by the corpus test and printed in pytest's terminal summary."""

from __future__ import annotations

from dataclasses import dataclass, field

import pytest


@dataclass
class GuardStats:
    """Precision and recall of the guard over the corpus, and the samples it got wrong."""

    hostile: int = 0
    benign: int = 0
    true_positives: int = 0
    false_positives: int = 0
    threshold: float = 0.0
    missed: list[str] = field(default_factory=list)
    false_alarms: list[str] = field(default_factory=list)

    @property
    def recall(self) -> float:
        return self.true_positives / self.hostile if self.hostile else 0.0

    @property
    def precision(self) -> float:
        flagged = self.true_positives + self.false_positives
        return self.true_positives / flagged if flagged else 0.0

    def line(self) -> str:
        return (
            f"injection guard: precision {self.precision:.2f} recall {self.recall:.2f} "
            f"(n={self.hostile} hostile, {self.benign} benign, threshold {self.threshold})"
        )


_STATS = pytest.StashKey[GuardStats]()


@pytest.fixture
def guard_stats(request: pytest.FixtureRequest) -> GuardStats:
    """A fresh record for this run's corpus figures, kept on the config for the terminal summary."""
    stats = GuardStats()
    request.config.stash[_STATS] = stats
    return stats


def _short(text: str) -> str:
    flat = " ".join(text.split())
    return flat if len(flat) <= 90 else flat[:87] + "..."


def pytest_terminal_summary(terminalreporter: pytest.TerminalReporter, config: pytest.Config) -> None:
    stats = config.stash.get(_STATS, None)
    if stats is None or not stats.hostile:
        return
    terminalreporter.write_line(stats.line())
    for text in stats.missed:
        terminalreporter.write_line(f"  missed (hostile, not flagged): {_short(text)!r}")
    for text in stats.false_alarms:
        terminalreporter.write_line(f"  false alarm (benign, flagged): {_short(text)!r}")
