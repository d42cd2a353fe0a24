"""``agentic-uav eval stats RESULTS``: the statistics report of a results file.

Exit status: 0 on success, 2 on bad input (the message names the file, line or record, and column).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TextIO

from agentic_core.contracts.errors import AgenticUAVError, report_error
from evaluation.stats.errors import InputError

PROG = "agentic-uav eval stats"


def configure_parser(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """Add this command's arguments to ``parser`` (for wiring into the main CLI's subparsers)."""
    parser.add_argument("results", metavar="RESULTS", help="results file: CSV/TSV, JSON list of objects, or JSONL")
    parser.add_argument("--group", metavar="COL", help="column holding the groups (default: detected)")
    parser.add_argument(
        "--value",
        metavar="COL",
        action="append",
        help="outcome column (repeat, or separate with commas; a column's own name wins; default: detected)",
    )
    parser.add_argument(
        "--categorical", metavar="COL", action="append", default=[], help="treat a numeric column as categories"
    )
    parser.add_argument("--alpha", type=float, default=0.05, help="significance level (default 0.05)")
    parser.add_argument("--baseline", metavar="GROUP", help="group for 'speed vs. baseline' (default: the fastest)")
    parser.add_argument(
        "--format", choices=("markdown", "latex", "json"), default="markdown", help="what to print (default markdown)"
    )
    parser.add_argument(
        "--out",
        metavar="DIR",
        type=Path,
        help="also write stats.md, stats.tex, stats.json and the PNG plots (stats_*.png) into DIR",
    )
    parser.set_defaults(handler=run)
    return parser


def _split(values: Sequence[str] | None) -> list[str] | None:
    """The names as given; the data set splits at commas once it knows the columns (a name may hold one)."""
    if not values:
        return None
    return [v.strip() for v in values if v.strip()]


def run(args: argparse.Namespace, stdout: TextIO | None = None, stderr: TextIO | None = None) -> int:
    from evaluation.stats.dataset import load_dataset
    from evaluation.stats.pipeline import analyze_dataset
    from evaluation.stats.plots import write_plots

    out = stdout or sys.stdout
    err = stderr or sys.stderr
    if not 0.0 < args.alpha < 1.0:
        print(f"{PROG}: error: --alpha must be between 0 and 1, got {args.alpha}", file=err)
        return 2
    try:
        dataset = load_dataset(
            args.results, group=args.group, values=_split(args.value), categorical=_split(args.categorical) or []
        )
        report = analyze_dataset(dataset, alpha=args.alpha, baseline=args.baseline)
    except InputError as exc:
        print(f"{PROG}: error: {exc}", file=err)
        return 2
    rendered = {"markdown": report.to_markdown, "latex": report.to_latex, "json": report.to_json}[args.format]()
    out.write(rendered if rendered.endswith("\n") else rendered + "\n")
    if args.out is not None:
        try:
            args.out.mkdir(parents=True, exist_ok=True)
            (args.out / "stats.md").write_text(report.to_markdown(), encoding="utf-8")
            (args.out / "stats.tex").write_text(report.to_latex(), encoding="utf-8")
            (args.out / "stats.json").write_text(report.to_json() + "\n", encoding="utf-8")
            write_plots(report, args.out, dataset)
        except OSError as exc:
            print(f"{PROG}: error: {args.out}: cannot write the report ({exc.strerror or exc})", file=err)
            return 2
        print(f"wrote {args.out / 'stats.md'}, {args.out / 'stats.tex'}, {args.out / 'stats.json'}", file=err)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point: ``main(["results.csv", "--group", "system"])`` returns the exit status."""
    parser = configure_parser(argparse.ArgumentParser(prog=PROG, description=__doc__))
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse exits on --help (0) and on usage errors (2)
        return int(exc.code) if isinstance(exc.code, int) else 2
    try:
        return run(args)
    except AgenticUAVError as exc:
        return report_error(PROG, exc, sys.stderr)


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
