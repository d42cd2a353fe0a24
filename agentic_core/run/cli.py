"""``agentic-uav run MISSION``: fly a mission end to end and write ``runs/<run-id>/`` with its report;
``agentic-uav run --resume RUN_ID`` goes on with a run that was killed.

The vehicle is the in-process simulator, or with ``--connect udp://HOST:PORT`` any MAVLink vehicle (``agentic-uav
sim`` in another process, PX4 SITL). Exit status: 0 when the mission completed or returned home, 1 when it was
aborted or failed (a critical event that got no alert fails the run), 2 for bad input (a mission, scene or option
that cannot be used; the message names the file, line and field), 3 when it is ``degraded``: every critical event
got its alert, but an alert reached only the outbox.

>>> args = build_parser().parse_args(["missions/hajj_emergency.yaml", "--speed", "max", "--param", "rounds=1"])
>>> args.speed, args.param, args.reasoner, args.resume
(None, ['rounds=1'], 'rules', None)
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pydantic import ValidationError

from flight.cli import parse_speed
from flight.sim.gains_file import load_gains

from ..console.cli import add_run_options, console_check, live_console, operator_for
from ..contracts.errors import AgenticUAVError, option_problem, report_error
from ..contracts.faults import FAULT_KINDS, Fault, parse_fault
from ..examples import resolve_mission, resolve_scene
from .detector_choice import parse_detector
from .responses import DEGRADED_EXIT
from .swarm_cli import refuse_swarm_mission

if TYPE_CHECKING:
    from ..agent.control import Operator
    from .runner import MissionRun

PROG = "agentic-uav run"


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog=PROG, description="Fly a mission on the simulated vehicle, end to end.")
    parser.add_argument(
        "mission", type=Path, nargs="?", metavar="MISSION", help="a mission file (YAML, JSON) or a shipped one's name"
    )
    parser.add_argument("--resume", metavar="RUN_ID", help="go on with the killed run RUN_ID of --runs-dir")
    parser.add_argument(
        "--connect", metavar="URL", help="fly the vehicle at this MAVLink address (udp://HOST:PORT), not the simulator"
    )
    parser.add_argument(
        "--gcs", metavar="HOST:PORT", help="the simulated vehicle also streams to this ground station, which may "
        "command it too (default 127.0.0.1:14550, or $AGENTIC_UAV_GCS; none: off)",
    )  # fmt: skip
    parser.add_argument(
        "--scene", type=Path, help="the simulated scene, a file or a shipped name (default: scenes/<mission>.yaml)"
    )
    parser.add_argument("--signing-key", type=Path, metavar="FILE", help="sign the --connect link with this key")
    parser.add_argument(
        "--reasoner", default="rules", choices=("yolo", "rules", "llm", "hybrid"), help="who assesses (default rules)"
    )
    parser.add_argument(
        "--llm", metavar="SPEC", help="the model for llm/hybrid, e.g. openai:gpt-4o (or AGENTIC_UAV_LLM)"
    )
    parser.add_argument("--speed", type=parse_speed, default=argparse.SUPPRESS,
                        help="times real time, or max (default max)")  # fmt: skip
    parser.add_argument(
        "--approval",
        choices=("approve", "decline", "ask"),
        default=None,
        help="steps that need an operator's yes: approve or decline them all (headless), or ask at the terminal, "
        "the mission paused until the answer (default approve)",
    )
    parser.add_argument("--decline", action="store_true", help="the same as --approval decline")
    parser.add_argument(
        "--approval-timeout-s", type=float, default=120.0, help="with --approval ask: no answer in this long declines"
    )
    parser.add_argument(
        "--tools", action="append", default=[], metavar="SOURCE",
        help="more tools for the mission: a module (mypkg.tools), a .py file, or a YAML/JSON file of HTTP endpoints "
        "(repeatable; as for validate and mcp serve)",
    )  # fmt: skip
    parser.add_argument("--runs-dir", type=Path, default=Path("runs"), help="where run folders go (default runs)")
    parser.add_argument("--param", action="append", default=[], metavar="NAME=VALUE", help="set a mission parameter")
    parser.add_argument("--seed", type=int, default=0, help="seed of the simulation and the detector (default 0)")
    parser.add_argument(
        "--max-wall-s", type=float, default=900.0, help="stop the mission and return home after this long (900)"
    )
    parser.add_argument("--camera-hz", type=float, default=30.0, help="frames per second of the camera (30)")
    parser.add_argument(
        "--render", action="store_true", help="the simulated camera renders pixels (640x480): alerts carry the frame"
    )
    parser.add_argument(
        "--gains", type=Path, metavar="FILE", help="the simulated vehicle's controller gains (tune.json of eval tune)"
    )
    parser.add_argument(
        "--fault", action="append", default=[], metavar="FAULT",
        help="inject a failure to rehearse a failsafe, repeatable: KIND[=VALUE]@WHEN, e.g. battery=18%%@S1 (when "
        "step S1 completes), gps_loss@t=40s (mission time); kinds: " + ", ".join(FAULT_KINDS),
    )  # fmt: skip
    parser.add_argument(
        "--memory",
        type=Path,
        metavar="FILE",
        help="the fleet's memory: recall what earlier runs found near here, record what this one finds",
    )
    parser.add_argument(
        "--detector", type=str, default="sim", metavar="sim|ours|onnx:PATH",
        help="the camera's detector: sim (statistical, default), ours (the shipped person detector) or a YOLO-style "
        "ONNX model; ours and onnx: render the camera's pixels",
    )  # fmt: skip
    parser.add_argument("--quiet", action="store_true", help="no progress lines")
    add_run_options(parser)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    from .runner import MissionRun, RunSettings
    from .settings import parse_gcs

    args = build_parser().parse_args(argv)
    progress = None if args.quiet else sys.stderr
    try:
        parse_gcs("none" if args.gcs is None else args.gcs)
    except ValueError as exc:
        print(f"{PROG}: error: --gcs: {exc}", file=sys.stderr)
        return 2
    try:
        console_check(args)
    except AgenticUAVError as exc:
        return report_error(PROG, exc, sys.stderr)
    operator = operator_for(args)
    if args.resume is not None:
        if (
            args.mission is not None
            or args.connect is not None
            or args.param
            or args.scene is not None
            or args.fault
            or args.tools
            or args.signing_key
        ):
            print(
                f"{PROG}: error: --resume takes the run's own mission, scene, vehicle, parameters, faults and tools",
                file=sys.stderr,
            )
            return 2
        overrides: dict[str, Any] = {}
        if args.approval is not None or args.decline:
            overrides["approval"] = args.approval or "decline"
        if "speed" in vars(args):
            overrides["speed"] = args.speed
        if args.gcs is not None:
            overrides["gcs"] = args.gcs
        return _fly(
            lambda: MissionRun.resume(args.runs_dir, args.resume, progress=progress, operator=operator, **overrides),
            args,
            operator,
        )
    if args.mission is None:
        print(f"{PROG}: error: give a MISSION, or --resume RUN_ID", file=sys.stderr)
        return 2
    params: dict[str, str] = {}
    for item in args.param:
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            print(f"{PROG}: error: --param takes NAME=VALUE, got {item!r}", file=sys.stderr)
            return 2
        params[name.strip()] = value.strip()
    faults: list[Fault] = []
    for text in args.fault:
        try:
            faults.append(parse_fault(text))
        except ValueError as exc:
            print(f"{PROG}: error: --fault {exc}", file=sys.stderr)
            return 2
    if args.decline and args.approval not in (None, "decline"):
        print(f"{PROG}: error: --decline contradicts --approval {args.approval}", file=sys.stderr)
        return 2
    if args.gcs is not None and args.connect is not None:
        print(f"{PROG}: error: --gcs is for the simulated vehicle; one at --connect streams itself", file=sys.stderr)
        return 2
    if args.signing_key is not None and args.connect is None:
        print(f"{PROG}: error: --signing-key goes with --connect (the simulator makes a key per run)", file=sys.stderr)
        return 2
    if args.gains is not None and args.connect is not None:
        print(f"{PROG}: error: --gains sets the simulated vehicle's controller; not one at --connect", file=sys.stderr)
        return 2
    try:
        mission = resolve_mission(args.mission)
        refuse_swarm_mission(mission)
        scene = None if args.scene is None else resolve_scene(args.scene)
        if args.gains is not None:
            load_gains(args.gains)  # a bad file is refused before anything starts
        parse_detector(args.detector)
    except AgenticUAVError as exc:
        return report_error(PROG, exc, sys.stderr)
    try:
        settings = RunSettings(
            mission=mission,
            scene=scene,
            reasoner=args.reasoner,
            llm=args.llm,
            speed=getattr(args, "speed", None),
            connect=args.connect,
            signing_key=args.signing_key,
            approval=args.approval or ("decline" if args.decline else "approve"),
            approval_timeout_s=args.approval_timeout_s,
            runs_dir=args.runs_dir,
            params=params,
            seed=args.seed,
            max_wall_s=args.max_wall_s,
            camera_hz=args.camera_hz,
            render=args.render,
            gains=args.gains,
            faults=faults,
            **({} if args.gcs is None else {"gcs": args.gcs}),
            tools=args.tools,
            memory=args.memory,
            detector=args.detector,
        )
    except ValidationError as exc:  # an option out of range (pydantic names it)
        print(f"{PROG}: error: {option_problem(exc)}", file=sys.stderr)
        return 2
    return _fly(lambda: MissionRun(settings, progress=progress, operator=operator), args, operator)


@contextmanager
def _signals_stop(run: MissionRun) -> Iterator[None]:
    """While the block runs, the first SIGINT or SIGTERM asks the run to stop (``abort`` by ``signal``); a second
    one exits at once, quietly, with status 130."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    signalled: list[str] = []

    def stop(signum: int, _frame: Any) -> None:
        # A handler runs in the main thread between two of its bytecodes, perhaps while it holds a lock the stop
        # needs (the bus's, the trace's): it only writes straight to the descriptor and hands the stop to a thread.
        if signalled or run.control.stop_requested() is not None:
            os.write(2, f"\n{PROG}: stopped at once\n".encode())
            os._exit(130)
        name = signal.Signals(signum).name
        signalled.append(name)
        os.write(2, f"\n{PROG}: {name}: stopping the run (again to stop at once)\n".encode())
        threading.Thread(target=run.control.abort, args=(f"{name} received",), kwargs={"by": "signal"},
                         name="signal-stop", daemon=True).start()  # fmt: skip

    previous = {sig: signal.signal(sig, stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def _fly(make: Callable[[], MissionRun], args: argparse.Namespace, operator: Operator | None = None) -> int:
    """Build a run with ``make``, fly it and print its outcome; the exit status says it: 0 completed or returned
    home, 3 degraded (an alert reached only the outbox), 1 anything else that happened, 2 for bad input (one line
    naming it, no traceback). Ctrl-C or SIGTERM
    stops the run through its control port (outcome ``interrupted``, report written, resumable with
    ``--resume``); a second one ends the process at once."""
    try:
        run = make()
        with _signals_stop(run), live_console(run, args, operator, sys.stderr):
            result = run.execute()
    except AgenticUAVError as exc:
        return report_error(PROG, exc, sys.stderr)
    except ValueError as exc:  # a bad value found below our own checks
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 2
    summary = result.summary
    print(f"{summary.run_id}: {summary.outcome}: {summary.mission} in {summary.sim_duration_s:.0f} s of flight; "
          f"report: {result.report}")  # fmt: skip
    if summary.outcome == "degraded":
        return DEGRADED_EXIT
    return 0 if summary.outcome in ("completed", "returned") else 1


__all__ = ["build_parser", "main"]
