"""``agentic-uav swarm run MISSION --vehicles N``: fly a swarm mission with N simulated F450s on one clock (or,
with ``--connect URL,URL,...``, the vehicles at those MAVLink addresses, one per UAV, every link signed with
``--signing-key FILE`` when given) and write ``runs/<swarm-id>/`` (see :mod:`agentic_core.run.swarm_run`);
``--fault ground_link@t=60s`` loses the ground link then (the UAVs allocate the rest by consensus, judging each
other alive by signed heartbeats); ``--approval ask|approve|decline`` answers approvals and, for a mission whose
operator verifies casualties (``verify: {by: operator}``, which asks by default), that question too. Exit status:
0 when every sector was covered and every casualty found, verified, alerted and served with the separation kept;
3 when all that held but a UAV was lost (its work moved) or an alert reached only the outbox; 1 when anything fell
short; 2 for bad input.

>>> args = build_parser().parse_args(["run", "missions/hajj_swarm.yaml", "--vehicles", "4", "--speed", "max"])
>>> args.vehicles, args.speed, args.connect, args.signing_key
(4, None, [], None)
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path

import yaml

from flight.cli import parse_speed

from ..contracts.errors import AgenticUAVError, InputError, report_error
from .swarm_faults import ground_link_lost_at

PROG = "agentic-uav swarm"


def _urls(text: str) -> list[str]:
    urls = [u.strip() for u in text.split(",") if u.strip()]
    if not urls:
        raise argparse.ArgumentTypeError("--connect needs at least one udp://HOST:PORT")
    return urls


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog=PROG, description="Fly a mission with several UAVs (a swarm).")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    run = sub.add_parser("run", help="fly a swarm mission end to end")
    run.add_argument("mission", type=Path, metavar="MISSION", help="a swarm mission file (with a swarm: block)")
    run.add_argument("--vehicles", type=int, metavar="N", help="simulated UAVs (default: the mission's vehicles)")
    run.add_argument("--connect", type=_urls, default=[], metavar="URL,URL,...",
                     help="fly the vehicles at these MAVLink addresses, one per UAV")  # fmt: skip
    run.add_argument("--signing-key", type=Path, metavar="FILE",
                     help="sign every --connect link with this MAVLink 2 key (32 bytes or 64 hex digits)")  # fmt: skip
    run.add_argument("--scene", type=Path, help="the simulated scene (default: scenes/<mission>.yaml)")
    run.add_argument("--speed", type=parse_speed, default=None, help="times real time, or max (default: max)")
    run.add_argument("--reasoner", default="rules", help="each UAV's reasoner (default: rules)")
    run.add_argument("--runs-dir", type=Path, default=Path("runs"), help="where the swarm's directory goes")
    run.add_argument("--seed", type=int, default=0, help="UAV i's simulator and camera use seed + i")
    run.add_argument("--rounds", type=int, help="surveys of every sector (default: the mission's rounds)")
    run.add_argument("--gcs", default="none", metavar="HOST:PORT",
                     help="every simulated vehicle streams here too (PX4: 127.0.0.1:14550)")  # fmt: skip
    run.add_argument("--px4-ports", action="store_true",
                     help="vehicle i streams to API port 14540+i too (PX4 SITL's multi-vehicle)")  # fmt: skip
    run.add_argument("--camera-hz", type=float, default=10.0, help="each UAV's camera rate (default 10)")
    run.add_argument("--max-wall-s", type=float, default=900.0, help="each UAV gives up (and lands) after this")
    run.add_argument("--approval", choices=("approve", "decline", "ask"), default=None,
                     help="approvals and the operator's verification: a headless answer, or ask the operator "
                          "(default: ask when the mission's verify is by: operator, else approve)")  # fmt: skip
    run.add_argument("--fault", action="append", default=[], metavar="ground_link@t=SECONDS",
                     help="lose the ground link then: the UAVs allocate what is left by consensus")  # fmt: skip
    return parser


def refuse_swarm_mission(mission: Path) -> None:
    """For ``agentic-uav run``: an :class:`InputError` naming the file and line when ``mission`` is a swarm mission
    (one drone cannot fly it: its steps call the ``swarm.*`` tools of a swarm run). A file that does not parse is
    left to the mission loader, which says why.

    >>> try:
    ...     refuse_swarm_mission(Path("missions/hajj_swarm.yaml"))
    ... except InputError as exc:
    ...     str(exc).split(": ")[0], "agentic-uav swarm run missions/hajj_swarm.yaml" in str(exc)
    ('missions/hajj_swarm.yaml:23', True)
    """
    try:
        root = yaml.compose(mission.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError):
        return
    if not isinstance(root, yaml.MappingNode):
        return
    for key, _ in root.value:
        if isinstance(key, yaml.ScalarNode) and key.value == "swarm":
            raise InputError(
                f"{mission}:{key.start_mark.line + 1}: a swarm mission (its swarm: block): fly it with "
                f"`agentic-uav swarm run {mission} --vehicles N`, not `agentic-uav run`"
            )


def main(argv: Sequence[str] | None = None) -> int:
    """Parse, fly, print the summary's outcome; the exit status says what happened."""
    args = build_parser().parse_args(list(sys.argv[1:] if argv is None else argv))
    from .swarm_run import SwarmSettings, run_swarm

    if args.vehicles is not None and args.vehicles < 1:
        return report_error(PROG, InputError(f"--vehicles {args.vehicles}: at least 1"), sys.stderr)
    try:
        ground_lost_s = ground_link_lost_at(args.fault)
    except InputError as exc:
        return report_error(PROG, exc, sys.stderr)
    settings = SwarmSettings(
        mission=args.mission, vehicles=args.vehicles, connect=args.connect, signing_key=args.signing_key,
        scene=args.scene, runs_dir=args.runs_dir,
        speed=args.speed, seed=args.seed, reasoner=args.reasoner, gcs=args.gcs, px4_ports=args.px4_ports,
        max_wall_s=args.max_wall_s, rounds=args.rounds, camera_hz=args.camera_hz, ground_link_lost_s=ground_lost_s,
        approval=args.approval,
    )  # fmt: skip
    try:
        summary = run_swarm(settings, progress=sys.stderr)
    except AgenticUAVError as exc:
        return report_error(PROG, exc, sys.stderr)
    print(json.dumps({k: summary[k] for k in ("swarm_id", "outcome", "exit", "problems", "separation")}, indent=2))
    code: int = summary["exit"]
    return code


__all__ = ["build_parser", "main", "refuse_swarm_mission"]
