"""A process that calls a side-effect tool once with an idempotency key, says so, and is killed with SIGKILL
before it can close anything: ``python -m tests.tools.idempotency_child AUDIT_FILE RUNS_FILE KEY``.

The tool appends a line to ``RUNS_FILE`` for each run, so the parent counts runs across processes."""

from __future__ import annotations

import os
import signal
import sys
from pathlib import Path
from typing import Any

from tools import ToolExecutor, ToolRegistry, ToolSpec, open_audit_log


def release_tool(runs: Path) -> ToolSpec:
    """``payload.release``: a side-effect tool whose runs are lines of ``runs``."""

    def release(args: dict[str, Any]) -> dict[str, Any]:
        with runs.open("a", encoding="utf-8") as file:
            file.write(f"{os.getpid()}\n")
        count = len(runs.read_text(encoding="utf-8").splitlines())
        return {"released": args["bay"], "run": count, "pid": os.getpid()}

    schema = {"type": "object", "properties": {"bay": {"type": "integer"}}, "required": ["bay"]}
    return ToolSpec.from_schema("payload.release", release, schema, side_effects=True)


def main(audit_path: str, runs_path: str, key: str) -> None:
    registry = ToolRegistry()
    registry.register(release_tool(Path(runs_path)))
    executor = ToolExecutor(registry, audit=open_audit_log(audit_path))
    result = executor.call("payload.release", {"bay": 2}, idempotency_key=key)
    sys.stdout.write(result.model_dump_json() + "\n")
    sys.stdout.flush()
    os.kill(os.getpid(), signal.SIGKILL)  # right after the call returned: no close, no flush of anything else


if __name__ == "__main__":
    main(*sys.argv[1:4])
