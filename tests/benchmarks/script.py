"""A benchmark script run as a user runs it (``python benchmarks/NAME ARGS``, a fresh process), for the smoke tests:
they check that it runs to the end and prints its table, never its timings."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
BENCHMARKS = ROOT / "benchmarks"


def run_script(name: str, *args: str, cwd: Path = ROOT, timeout_s: float = 300.0) -> subprocess.CompletedProcess[str]:
    """Run ``benchmarks/NAME`` with ``args`` in ``cwd``; whatever it exits with."""
    return subprocess.run(
        [sys.executable, str(BENCHMARKS / name), *args], capture_output=True, text=True, timeout=timeout_s, cwd=cwd
    )


def table(name: str, *args: str, cwd: Path = ROOT, timeout_s: float = 300.0) -> str:
    """What ``benchmarks/NAME`` prints, after it exits 0 (else the test fails showing the end of its stderr)."""
    proc = run_script(name, *args, cwd=cwd, timeout_s=timeout_s)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc.stdout
