"""The ``agentic-uav`` command line (also ``python -m agentic_core``).

Exit codes: 0 on success, 2 on bad input (with a message naming the file, line and field), 1 on other failures.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from . import __version__


def _cmd_demo(args: argparse.Namespace) -> int:
    from .demo import run_demo

    run_demo(Path(args.runs_dir), approve=not args.decline)
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="agentic-uav", description="Drones as agents: missions, tools, flight, eval.")
    parser.add_argument("--version", action="version", version=f"agentic-uavs {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    demo = sub.add_parser("demo", help="run the example patrol graph (checkpointed under runs/)")
    demo.add_argument("--runs-dir", default="runs", help="where run folders go (default: runs)")
    demo.add_argument("--decline", action="store_true", help="answer the operator approval with 'decline'")
    demo.set_defaults(func=_cmd_demo)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    code: int = args.func(args)
    return code


if __name__ == "__main__":
    sys.exit(main())
