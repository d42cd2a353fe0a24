"""``agentic-uav memory``: look into the fleet's memory and feed it knowledge.

    agentic-uav memory why KEY                 the chain behind a memory (KEY as cited: incident/RUN:SEQ)
    agentic-uav memory search QUERY [--near LAT,LON,M] [--knowledge]
    agentic-uav memory ingest FILES...         Markdown with source/version/valid_until front matter
    agentic-uav memory invalidate KEY --reason TEXT [--by NAME]
    agentic-uav memory feedback                the model fitted to the operators' answers, and what it moves

Every command takes ``--memory FILE`` (default ``runs/memory.db``, the file ``agentic-uav run --memory`` uses
when given the same path) and says how it searches: the offline model with BM25, or BM25 alone.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from agentic_core.contracts.errors import AgenticUAVError, InputError, report_error

from .feedback import FeedbackModel
from .fleet import FleetMemory
from .knowledge import ingest, search_knowledge

PROG = "agentic-uav memory"
DEFAULT = Path("runs") / "memory.db"


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog=PROG, description="the fleet's memory: explain, search, ingest, invalidate")
    parser.add_argument("--memory", type=Path, default=DEFAULT, metavar="FILE", help=f"the memory (default {DEFAULT})")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    why = sub.add_parser("why", help="the chain behind a memory: what it says, where from, every change, what it cites")
    why.add_argument("key", metavar="KEY", help="as a rationale cites it: KIND/KEY, e.g. incident/RUN:12")
    search = sub.add_parser("search", help="memories near a place, or knowledge, most relevant first")
    search.add_argument("query", nargs="?", default=None)
    search.add_argument("--near", metavar="LAT,LON,M", help="within M metres of LAT,LON (default: anywhere)")
    search.add_argument("--knowledge", action="store_true", help="search the ingested documents instead")
    search.add_argument("--limit", type=int, default=5)
    ing = sub.add_parser("ingest", help="chunk Markdown documents into the memory (source, version, valid_until)")
    ing.add_argument("files", nargs="+", type=Path, metavar="FILE")
    inv = sub.add_parser("invalidate", help="mark a memory as no longer believed (it is kept, with why)")
    inv.add_argument("key", metavar="KEY")
    inv.add_argument("--reason", required=True)
    inv.add_argument("--by", default="operator")
    fb = sub.add_parser("feedback", help="the model fitted to the operators' approvals, declines and edits")
    fb.add_argument("--still-s", type=float, default=10.0, help="the rules' stillness threshold (default 10 s)")
    return parser


def _near(text: str) -> tuple[float, float, float]:
    try:
        lat, lon, m = (float(x) for x in text.split(","))
    except ValueError:
        raise InputError(f"--near takes LAT,LON,METRES (e.g. 21.4206,39.8728,200), got {text!r}") from None
    return lat, lon, m


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        if args.command != "ingest" and not args.memory.exists():
            raise InputError(f"{args.memory}: no memory there yet (a run with --memory {args.memory} makes one)")
        if args.command == "ingest":
            args.memory.parent.mkdir(parents=True, exist_ok=True)
        fleet = FleetMemory(args.memory)
        try:
            return _command(args, fleet)
        finally:
            fleet.close()
    except AgenticUAVError as exc:
        return report_error(PROG, exc, sys.stderr)


def _command(args: argparse.Namespace, fleet: FleetMemory) -> int:
    print(f"memory: {args.memory}; search: {fleet.search_mode}", file=sys.stderr)
    if args.command == "why":
        lines = fleet.why(args.key)
        print("\n".join(lines))
        return 0 if not lines[0].endswith("not in this memory") else 1
    if args.command == "ingest":
        keys = ingest(fleet.store, list(args.files))
        print(f"ingested {len(keys)} chunks from {len(args.files)} documents")
        return 0
    if args.command == "feedback":
        if not args.still_s > 0:
            raise InputError(f"--still-s must be a positive number of seconds, got {args.still_s}")
        print("\n".join(FeedbackModel.load(fleet, args.still_s).describe()))
        return 0
    if args.command == "invalidate":
        fleet.invalidate(args.key, args.reason, by=args.by)
        print(f"{args.key}: invalidated ({args.reason})")
        return 0
    if args.knowledge:
        if not args.query:
            raise InputError("search --knowledge needs a QUERY")
        for hit in search_knowledge(fleet.store, args.query, limit=args.limit):
            v = hit.value
            print(f"{v['file']} v{v['version']} (valid until {v['valid_until']}): {v['heading']}")
            print("  " + v["text"].replace("\n", "\n  "))
        return 0
    if args.near is None:
        raise InputError("search needs --near LAT,LON,M (or --knowledge)")
    lat, lon, m = _near(args.near)
    for r in fleet.recall(lat, lon, within_m=m, query=args.query, limit=args.limit):
        away = f"{r.distance_m:.0f} m" if r.distance_m is not None else "?"
        print(f"{r.kind}/{r.key} ({away}): {r.text}")
    return 0


__all__ = ["build_parser", "main"]
