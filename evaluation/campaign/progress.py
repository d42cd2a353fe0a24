"""The campaign's progress line on stderr: records done of the total, the rate (and each system's), the time left.

On a terminal the line is redrawn in place after every record; to a file or pipe a line is written at most every
``every_s`` seconds (and at the end), so logs stay short. ``quiet`` writes nothing. With ``file`` (the campaign's
``progress.json``) the same counts are also rewritten there, atomically, at most every second and at the start and
the end, for the operator console to show (:class:`agentic_core.contracts.campaign_progress.CampaignProgress`).

>>> import io
>>> out = io.StringIO()
>>> progress = Progress(total=4, already=2, stream=out, clock=iter([0.0, 2.0, 2.0]).__next__, every_s=0.0)
>>> progress.advance(2, "gen-2", systems=["yolo", "rules"])
>>> print(out.getvalue().strip())
campaign: 4/4 records (100%), 1.00 records/s, ETA 0:00:00, last gen-2; per system: yolo 0.50/s, rules 0.50/s
"""

from __future__ import annotations

import os
import sys
import time
from collections import Counter
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TextIO

from agentic_core.contracts.campaign_progress import CampaignProgress, SystemProgress

FILE_EVERY_S = 1.0
"""``progress.json`` is rewritten at most this often (wall seconds)."""


class Progress:
    """Counts finished records and reports them (see the module docs); ``already`` were done before this run."""

    def __init__(
        self,
        total: int,
        already: int = 0,
        *,
        stream: TextIO | None = None,
        quiet: bool = False,
        every_s: float = 10.0,
        clock: Callable[[], float] = time.monotonic,
        file: Path | None = None,
    ) -> None:
        self.total = total
        self.done = already
        self.already = already
        self.stream = stream if stream is not None else sys.stderr
        self.quiet = quiet
        self.every_s = every_s
        self.clock = clock
        self.started = clock()
        self._last_line = -float("inf")
        self._tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self._drawn = False
        self._systems: Counter[str] = Counter()
        self._failed: Counter[str] = Counter()
        self._before: Counter[str] = Counter()
        self._failed_before: Counter[str] = Counter()
        self.file = file
        self._wall0 = time.time()
        self._last_file = -float("inf")
        self._label = ""
        self._save(force=True)

    def note(self, text: str) -> None:
        """A message of its own line (resuming, workers, ...)."""
        if not self.quiet:
            self._clear()
            print(f"campaign: {text}", file=self.stream, flush=True)

    def earlier(self, systems: Sequence[str], failed: Sequence[str] = ()) -> None:
        """The records an earlier run of the campaign finished (``already`` of them), by system, and the system of
        each that has an error: counted in ``progress.json``'s totals, not in this run's rates."""
        self._before.update(systems)
        self._failed_before.update(failed)
        self._save(force=True)

    def advance(self, records: int, label: str = "", systems: Sequence[str] = (), failed: Sequence[str] = ()) -> None:
        """``records`` more records are finished (the last of them about ``label``; ``systems`` names each
        record's system, for the per-system rates; ``failed`` the system of each that has an error)."""
        self.done += records
        self._systems.update(systems)
        self._failed.update(failed)
        self._label = label or self._label
        self._save(force=self.done >= self.total)
        if self.quiet:
            return
        now = self.clock()
        if self._tty:
            self.stream.write("\r\x1b[2K" + self.line(now, label))
            self.stream.flush()
            self._drawn = True
        elif now - self._last_line >= self.every_s or self.done >= self.total:
            print(self.line(now, label), file=self.stream, flush=True)
            self._last_line = now

    def finish(self) -> None:
        """End the redrawn line (a terminal gets its newline); ``progress.json`` says the campaign ended."""
        self._save(force=True, state="ended")
        if self._drawn and not self.quiet:
            self.stream.write("\n")
            self.stream.flush()
            self._drawn = False

    def line(self, now: float, label: str = "") -> str:
        elapsed = max(now - self.started, 1e-9)
        fresh = self.done - self.already
        rate = fresh / elapsed
        left = self.total - self.done
        eta = _clock_text(left / rate) if rate > 0 else "?"
        share = 100.0 * self.done / self.total if self.total else 100.0
        last = f", last {label}" if label else ""
        per = ", ".join(f"{name} {count / elapsed:.2f}/s" for name, count in self._systems.items())
        per = f"; per system: {per}" if per else ""
        return f"campaign: {self.done}/{self.total} records ({share:.0f}%), {rate:.2f} records/s, ETA {eta}{last}{per}"

    def state(self, state: str = "running") -> CampaignProgress | None:
        """The counts as ``progress.json`` holds them (None without a file)."""
        if self.file is None:
            return None
        now = self.clock()
        elapsed = max(now - self.started, 1e-9)
        rate = (self.done - self.already) / elapsed
        names = [*self._before, *(n for n in self._systems if n not in self._before)]
        systems = {
            name: SystemProgress(done=self._before[name] + self._systems[name],
                                 failed=self._failed_before[name] + self._failed[name],
                                 rate_per_s=self._systems[name] / elapsed)
            for name in names
        }  # fmt: skip
        failed = sum(self._failed.values()) + sum(self._failed_before.values())
        return CampaignProgress(
            campaign=self.file.parent.name, state="ended" if state == "ended" else "running", total=self.total,
            done=self.done, failed=failed, rate_per_s=rate,
            eta_s=(self.total - self.done) / rate if rate > 0 else None, systems=systems, last=self._label,
            started_at=self._wall0, updated_at=time.time(),
        )  # fmt: skip

    def _save(self, *, force: bool = False, state: str = "running") -> None:
        if self.file is None:
            return
        now = self.clock()
        if not force and now - self._last_file < FILE_EVERY_S:
            return
        progress = self.state(state)
        if progress is None:
            return
        self._last_file = now
        tmp = self.file.with_name(f".{self.file.name}.{os.getpid()}.tmp")
        try:
            tmp.write_text(progress.model_dump_json(), encoding="utf-8")
            os.replace(tmp, self.file)
        except OSError:  # the console's view only: a campaign never fails over it
            tmp.unlink(missing_ok=True)

    def _clear(self) -> None:
        if self._drawn:
            self.stream.write("\r\x1b[2K")
            self._drawn = False


def _clock_text(seconds: float) -> str:
    total = round(seconds)
    hours, rest = divmod(total, 3600)
    minutes, secs = divmod(rest, 60)
    return f"{hours}:{minutes:02d}:{secs:02d}"


__all__ = ["Progress"]
