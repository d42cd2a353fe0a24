"""``agentic-uav console``: browse the runs of ``--runs-dir`` in the browser (replay a finished run with a time
slider; follow a running one), and the options ``agentic-uav run --console`` adds to serve the live run.

>>> args = build_parser().parse_args(["--port", "0"])
>>> args.host, args.port, str(args.runs_dir)
('127.0.0.1', 0, 'runs')
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

from ..contracts.errors import AgenticUAVError, report_error
from ..contracts.extras import require
from .access import TOKEN_ENV, check_bind
from .server import ConsoleOperator, ConsoleServer, watch

if TYPE_CHECKING:
    from ..run.runner import MissionRun

PROG = "agentic-uav console"
DEFAULT_PORT = 8765


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog=PROG, description="The operator console in the browser: replay runs.")
    parser.add_argument("--runs-dir", type=Path, default=Path("runs"), help="where run folders are (default runs)")
    parser.add_argument("--campaigns-dir", type=Path, help="where campaign folders are, shown with their progress "
                        "(default: --runs-dir)")  # fmt: skip
    parser.add_argument("--host", default="127.0.0.1", help="the address to listen on (default 127.0.0.1; any "
                        f"other needs a token: --token or ${TOKEN_ENV})")  # fmt: skip
    parser.add_argument("--port", type=int, default=DEFAULT_PORT, help=f"the port (default {DEFAULT_PORT}; 0: any)")
    parser.add_argument("--token", help=f"the token pages must give (default ${TOKEN_ENV}, else a fresh one)")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        server = ConsoleServer(args.runs_dir, host=args.host, port=args.port, campaigns_dir=args.campaigns_dir,
                               token=args.token or os.environ.get(TOKEN_ENV) or None).start()  # fmt: skip
    except AgenticUAVError as exc:
        return report_error(PROG, exc, sys.stderr)
    print(f"console: {server.url}  (Ctrl-C to stop)", file=sys.stderr, flush=True)
    stopped = threading.Event()
    previous = {sig: signal.signal(sig, lambda *_: stopped.set()) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        while not stopped.wait(0.5) and server.serving:
            pass
    finally:
        server.stop()
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    return 0


def add_run_options(parser: argparse.ArgumentParser) -> None:
    """``agentic-uav run``'s console options."""
    parser.add_argument("--console", action="store_true", help="watch and steer the run in the browser (with "
                        "--approval ask, approvals are answered there)")  # fmt: skip
    parser.add_argument("--console-host", default="127.0.0.1", help=f"the console's address (default 127.0.0.1; "
                        f"any other needs ${TOKEN_ENV})")  # fmt: skip
    parser.add_argument("--console-port", type=int, default=DEFAULT_PORT, help=f"its port (default {DEFAULT_PORT})")


def console_check(args: argparse.Namespace) -> None:
    """Before a run is built: :class:`InputError` when ``--console`` would listen beyond this machine without a
    token, or its extra is not installed."""
    if getattr(args, "console", False):
        check_bind(args.console_host, os.environ.get(TOKEN_ENV) or None)
        for module in ("starlette", "uvicorn", "sse_starlette"):
            require(module, "console")


def operator_for(args: argparse.Namespace) -> ConsoleOperator | None:
    """The operator of a run with ``--console --approval ask``: the page answers, not the terminal."""
    return ConsoleOperator(args.approval_timeout_s) if getattr(args, "console", False) else None


@contextmanager
def live_console(run: MissionRun, args: argparse.Namespace, operator: Any, out: TextIO) -> Iterator[None]:
    """With ``--console``: serve ``run`` while the block flies it, and print where to open it."""
    if not getattr(args, "console", False):
        yield
        return
    if isinstance(operator, ConsoleOperator):
        operator.control = run.control
    server = ConsoleServer(args.runs_dir, host=args.console_host, port=args.console_port,
                           token=os.environ.get(TOKEN_ENV) or None, live=watch(run)).start()  # fmt: skip
    print(f"console: {server.url}", file=out, flush=True)
    try:
        yield
    finally:
        server.stop()


__all__ = ["add_run_options", "build_parser", "console_check", "live_console", "main", "operator_for"]
