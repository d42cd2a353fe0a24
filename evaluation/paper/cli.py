"""``agentic-uav eval paper``: recompute the paper's statistics from its published summary figures.

Exit status: 0 on success, 2 on a usage error.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TextIO

from agentic_core.contracts.errors import AgenticUAVError, report_error

PROG = "agentic-uav eval paper"


def configure_parser(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """Add this command's arguments to ``parser`` (for wiring into the main CLI's subparsers)."""
    parser.add_argument(
        "--format", choices=("text", "markdown", "json"), default="text", help="output format (default text)"
    )
    parser.add_argument("--out", metavar="FILE", type=Path, help="write the table to FILE instead of stdout")
    parser.set_defaults(handler=run)
    return parser


def run(args: argparse.Namespace, stdout: TextIO | None = None, stderr: TextIO | None = None) -> int:
    from evaluation.paper.reproduce import reproduce

    out = stdout or sys.stdout
    err = stderr or sys.stderr
    rep = reproduce()
    text = {"text": rep.to_text, "markdown": rep.to_markdown, "json": rep.to_json}[args.format]()
    if not text.endswith("\n"):
        text += "\n"
    if args.out is None:
        out.write(text)
        return 0
    try:
        args.out.write_text(text, encoding="utf-8")
    except OSError as exc:
        print(f"{PROG}: error: {args.out}: cannot write ({exc.strerror or exc})", file=err)
        return 2
    print(f"wrote {args.out}", file=err)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point: ``main(["--format", "markdown"])`` returns the exit status."""
    parser = configure_parser(argparse.ArgumentParser(prog=PROG, description=__doc__))
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:
        return int(exc.code) if isinstance(exc.code, int) else 2
    try:
        return run(args)
    except AgenticUAVError as exc:
        return report_error(PROG, exc, sys.stderr)


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
