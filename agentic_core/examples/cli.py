"""``agentic-uav examples``: list the shipped missions and scenes; ``agentic-uav examples copy DIR`` writes them
out for editing (never over existing files without ``--force``). Exit status 2 for a copy that cannot be made.

>>> build_parser().parse_args(["copy", "my-missions", "--force"]).force
True
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from ..contracts.errors import AgenticUAVError, report_error
from . import copy_examples, examples_root, shipped_missions, shipped_scenes

PROG = "agentic-uav examples"


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog=PROG,
        description="The missions and scenes shipped with agentic-uavs. Fly one by name: agentic-uav run NAME.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.add_parser("list", help="list the shipped missions and scenes (the default)")
    copy = sub.add_parser("copy", help="write the shipped missions and scenes to DIR/missions and DIR/scenes")
    copy.add_argument("dest", type=Path, metavar="DIR")
    copy.add_argument("--force", action="store_true", help="overwrite files that are already there")
    return parser


def _list() -> None:
    missions, scenes = shipped_missions(), shipped_scenes()
    width = max((len(e.name) for e in [*missions, *scenes]), default=0)
    print("missions (agentic-uav run NAME):")
    for m in missions:
        print(f"  {m.name:<{width}}  {m.summary}  [scene: {m.scene or 'none'}]")
    print("scenes (agentic-uav run MISSION --scene NAME):")
    for s in scenes:
        print(f"  {s.name:<{width}}  {s.summary}")
    print(f"from {examples_root()}; copy them to edit: agentic-uav examples copy DIR")


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        if args.command == "copy":
            written = copy_examples(args.dest, force=args.force)
            print(f"wrote {len(written)} files to {args.dest}; fly one: agentic-uav run {args.dest}/missions/NAME.yaml")
        else:
            _list()
    except AgenticUAVError as exc:
        return report_error(PROG, exc, sys.stderr)
    return 0


__all__ = ["build_parser", "main"]
