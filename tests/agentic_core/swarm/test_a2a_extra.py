"""Without the ``a2a`` extra the A2A modules fail to import with the command that installs it, not a bare
ModuleNotFoundError; the rest of the swarm imports without it."""

from __future__ import annotations

import subprocess
import sys

PROBE = """
import importlib, sys
sys.modules["a2a"] = None  # as if a2a-sdk were not installed
import agentic_core.swarm.signing, agentic_core.swarm.contract_net, agentic_core.swarm.deconflict
from agentic_core.contracts.extras import MissingExtra
for module in ("card", "a2a_server", "a2a_client"):
    try:
        importlib.import_module("agentic_core.swarm." + module)
    except MissingExtra as exc:
        print(module, exc.extra, exc)
"""


def test_a_missing_sdk_names_the_extra() -> None:
    proc = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    lines = proc.stdout.splitlines()
    assert [line.split()[:2] for line in lines] == [["card", "a2a"], ["a2a_server", "a2a"], ["a2a_client", "a2a"]]
    assert all(line.endswith("pip install 'agentic-uavs[a2a]'") for line in lines)
