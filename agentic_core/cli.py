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


EVAL_COMMANDS = ("stats", "paper")


def _run_eval(command: str, argv: Sequence[str]) -> int:
    """``eval stats|paper`` parse their own arguments (and ``--help``) in the evaluation package.

    Imported here, not at start-up: the statistics stack (scipy, statsmodels) takes over a second to load.
    """
    if command == "stats":
        from evaluation.stats.cli import main as stats_main

        return stats_main(argv)
    from evaluation.paper.cli import main as paper_main

    return paper_main(argv)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="agentic-uav", description="Drones as agents: missions, tools, flight, eval.")
    parser.add_argument("--version", action="version", version=f"agentic-uavs {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    demo = sub.add_parser("demo", help="run the example patrol graph (checkpointed under runs/)")
    demo.add_argument("--runs-dir", default="runs", help="where run folders go (default: runs)")
    demo.add_argument("--decline", action="store_true", help="answer the operator approval with 'decline'")
    demo.set_defaults(func=_cmd_demo)

    evaluate = sub.add_parser("eval", help="statistics on results files; reproduce the paper's statistics")
    eval_sub = evaluate.add_subparsers(dest="eval_command", metavar="EVAL_COMMAND", required=True)
    for name, text in (
        ("stats", "the paper's statistics pipeline on a results file (see: agentic-uav eval stats --help)"),
        ("paper", "recompute the paper's statistics from its published figures (agentic-uav eval paper --help)"),
    ):
        eval_sub.add_parser(name, help=text, add_help=False)  # listed here; parsed by _run_eval
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if len(argv) >= 2 and argv[0] == "eval" and argv[1] in EVAL_COMMANDS:
        return _run_eval(argv[1], argv[2:])
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    code: int = args.func(args)
    return code


if __name__ == "__main__":
    sys.exit(main())
