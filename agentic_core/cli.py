"""The ``agentic-uav`` command line (also ``python -m agentic_core``).

Exit codes: 0 on success, 2 on bad input (with a message naming the file, line and field), 1 on other failures.
"""

from __future__ import annotations

import argparse
import importlib
import math
import sys
from collections.abc import Sequence
from pathlib import Path

from tools.cli import add_source_options

from . import __version__
from .contracts.errors import AgenticUAVError, report_error
from .examples import ExampleError, resolve_mission, resolve_scene

DEMO_MISSION = Path(__file__).resolve().parents[1] / "missions" / "hajj_emergency.yaml"
"""What ``agentic-uav demo`` and ``make demo`` fly: the paper's emergency scenario, on the embedded defaults."""


def demo_argv(runs_dir: str, decline: bool) -> list[str]:
    """The ``agentic-uav run`` arguments of the demo (``make demo`` runs ``agentic-uav demo``: one demo)."""
    return [str(DEMO_MISSION), "--runs-dir", runs_dir] + (["--decline"] if decline else [])


def _cmd_demo(args: argparse.Namespace) -> int:
    """The demo flies on the embedded defaults, which send no e-mail: a run that is ``degraded`` only because no
    mail server is set is the demo working as designed (exit 0, said); one whose configured server failed is not."""
    import os

    from .run.cli import main as run_main
    from .run.responses import DEGRADED_EXIT

    code = run_main(demo_argv(args.runs_dir, args.decline))
    if code == DEGRADED_EXIT and not os.environ.get("AGENTIC_UAV_SMTP_HOST"):
        print(
            "demo: no mail server is set (AGENTIC_UAV_SMTP_HOST), so the alert went to the run's outbox "
            "(alerts/*.eml) and the run says `degraded`, as it would in the field; the demo itself went as designed",
            file=sys.stderr,
        )
        return 0
    return code


EVAL_COMMANDS = ("stats", "paper", "campaign", "paper-campaign", "feedback", "tune")
DELEGATED = {
    "tools": "tools.cli",
    "mcp": "tools.mcp.cli",
    "sim": "flight.cli",
    "run": "agentic_core.run.cli",
    "swarm": "agentic_core.run.swarm_cli",
    "examples": "agentic_core.examples.cli",
    "console": "agentic_core.console.cli",
    "memory": "agentic_core.memory.cli",
}
"""Commands whose layer parses its own arguments (and ``--help``)."""


def _run_eval(command: str, argv: Sequence[str]) -> int:
    """``eval stats|paper|campaign`` parse their own arguments (and ``--help``) in the evaluation package.

    Imported here, not at start-up: the statistics stack (scipy, statsmodels) takes over a second to load.
    """
    if command == "stats":
        from evaluation.stats.cli import main as stats_main

        return stats_main(argv)
    if command == "campaign":
        from evaluation.campaign.cli import main as campaign_main

        return campaign_main(argv)
    if command == "tune":
        from evaluation.tuning.cli import main as tune_main

        return tune_main(argv)
    if command == "feedback":
        from evaluation.campaign.feedback_study import main as feedback_main

        return feedback_main(argv)
    if command == "paper-campaign":
        from evaluation.campaign.paper_campaign import main as paper_campaign_main

        return paper_campaign_main(argv)
    from evaluation.paper.cli import main as paper_main

    return paper_main(argv)


def _cmd_validate(args: argparse.Namespace) -> int:
    from tools.errors import ToolDefinitionError
    from tools.loading import build_registry

    from .mission.source import MissionError
    from .mission.validate import iter_steps, load_mission
    from .run.own_tools import register_stand_ins, reserved_names

    try:
        registry = build_registry(args.tools, builtins=not args.no_builtins, reserved=reserved_names())
        register_stand_ins(registry, swarm=True)  # the run's own tools: their names, arguments and scopes
        home = _validate_home(args)
    except (ToolDefinitionError, ValueError) as exc:
        print(f"agentic-uav validate: error: {exc}", file=sys.stderr)
        return 2
    failed = 0
    for name in args.files:
        try:
            plan = load_mission(resolve_mission(Path(name)), tools=registry, home=home)
        except (MissionError, ExampleError) as exc:
            failed += 1
            print(exc, file=sys.stderr)
            continue
        nested = sum(1 for _ in iter_steps(plan)) - len(plan.steps)
        steps = f"{len(plan.steps)} step{'s' if len(plan.steps) != 1 else ''}"
        triggers = f"{len(plan.triggers)} trigger{'s' if len(plan.triggers) != 1 else ''}"
        extra = f" (+{nested} nested or in triggers)" if nested else ""
        print(f"{name}: ok: plan {plan.plan_id!r}, {steps}{extra}, {triggers}; tools checked against {len(registry)}")
    return 2 if failed else 0


def _validate_home(args: argparse.Namespace) -> tuple[float, float]:
    """Where ``validate`` measures north/east positions from: ``--home``, else the ``--scene``'s home, else the
    simulator's default home (where ``agentic-uav run`` takes off without a scene)."""
    if args.home is not None:
        lat, sep, lon = args.home.partition(",")
        try:
            home = float(lat), float(lon)
        except ValueError:
            home = (math.nan, math.nan)
        if not sep or not (-90 <= home[0] <= 90 and -180 <= home[1] <= 180):
            raise ValueError(f"--home takes LAT,LON in degrees, got {args.home!r}")
        return home
    if args.scene is not None:
        from flight.sim.scene_file import load_scene

        scene = load_scene(resolve_scene(Path(args.scene)))  # a bad scene file is bad input: main reports it, exit 2
        return scene.home.lat_deg, scene.home.lon_deg
    from flight.sim.environment import DEFAULT_HOME_LAT_DEG, DEFAULT_HOME_LON_DEG

    return DEFAULT_HOME_LAT_DEG, DEFAULT_HOME_LON_DEG


def _cmd_plan(args: argparse.Namespace) -> int:
    from .mission import MissionError, load_mission
    from .mission.layers import layers
    from .mission.params import initial_state

    try:
        plan = load_mission(resolve_mission(Path(args.file)))
        overrides = dict(_split_param(p) for p in args.param)
        params = initial_state(plan, overrides)["params"]
    except MissionError as exc:
        print(exc, file=sys.stderr)
        return 2
    except ValueError as exc:
        print(f"agentic-uav plan: error: {exc}", file=sys.stderr)
        return 2
    if args.mermaid:
        from .mission.mermaid import mission_mermaid

        print(mission_mermaid(plan), end="")
        return 0
    print(f"{plan.plan_id}: {plan.goal}")
    print(f"params: {params}")
    for i, layer in enumerate(layers(plan)):
        print(f"  superstep {i + 1}: {', '.join(layer)}")
    for trigger in plan.triggers:
        print(f"  trigger {trigger.id}: when {trigger.when} -> {', '.join(s.id for s in trigger.steps)}")
    return 0


def _split_param(text: str) -> tuple[str, str]:
    name, sep, value = text.partition("=")
    if not sep or not name:
        raise ValueError(f"--param takes name=value, got {text!r}")
    return name.strip(), value.strip()


SCHEMAS = {
    "policy-graph": ("agentic_core.contracts.policy_graph", "mission_json_schema", "mission files (the PolicyGraph)"),
    "mission": ("agentic_core.contracts.policy_graph", "mission_json_schema", "the same as policy-graph"),
    "world-model": ("agentic_core.contracts.world_model", "world_model_schema", "the World Model Contract"),
    "detection": ("agentic_core.contracts.camera", "detection_json_schema", "one detection in a camera frame"),
    "frame": ("agentic_core.contracts.camera", "frame_json_schema", "a camera frame's metadata"),
    "assessment": ("agentic_core.contracts.assessment", "assessment_json_schema", "a reasoner's Assessment"),
    "plan": ("agentic_core.contracts.plan", "proposal_json_schema", "a reasoner's proposed steps (the Plan)"),
    "decision": ("agentic_core.contracts.assessment", "decision_json_schema", "a timed DecisionRecord"),
    "tool-result": ("agentic_core.contracts.tool_result", "tool_result_json_schema", "what a tool call returns"),
    "run-event": ("agentic_core.contracts.events", "run_event_json_schema", "one line of a run's trace.jsonl"),
    "telemetry": ("agentic_core.contracts.telemetry", "telemetry_json_schema", "one telemetry sample"),
    "scene": ("flight.sim.scene_file", "scene_json_schema", "simulated scene files (scenes/*.yaml)"),
    "campaign-progress": (
        "agentic_core.contracts.campaign_progress",
        "campaign_progress_json_schema",
        "a campaign's progress.json",
    ),
}
"""``agentic-uav schema NAME``: the module and function exporting each contract's JSON Schema."""


def _cmd_schema(args: argparse.Namespace) -> int:
    import json

    names = "\n".join(f"  {name:<13} {text}" for name, (_, _, text) in SCHEMAS.items())
    if args.list:
        print(names)
        return 0
    if args.which not in SCHEMAS:
        given = "no NAME given" if args.which is None else f"unknown schema {args.which!r}"
        print(f"agentic-uav schema: error: {given}; the schemas are:\n{names}", file=sys.stderr)
        return 2
    module, function, _ = SCHEMAS[args.which]
    print(json.dumps(getattr(importlib.import_module(module), function)(), indent=2))
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="agentic-uav", description="Drones as agents: missions, tools, flight, eval.")
    parser.add_argument("--version", action="version", version=f"agentic-uavs {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    demo = sub.add_parser(
        "demo", help="fly the emergency mission end to end (agentic-uav run missions/hajj_emergency.yaml)"
    )
    demo.add_argument("--runs-dir", default="runs", help="where run folders go (default: runs)")
    demo.add_argument("--decline", action="store_true", help="the operator says no to landing near people")
    demo.set_defaults(func=_cmd_demo)

    validate = sub.add_parser("validate", help="check mission files; every problem as file:line:col: message")
    validate.add_argument("files", nargs="+", metavar="MISSION", help="mission YAML or JSON files, or shipped names")
    add_source_options(validate)
    validate.add_argument(
        "--home", metavar="LAT,LON", help="where north/east positions are measured from (default: the scene's home)"
    )
    validate.add_argument(
        "--scene", metavar="SCENE", help="take home from this scene file (default: the simulator's default home)"
    )
    validate.set_defaults(func=_cmd_validate)

    plan = sub.add_parser("plan", help="show how a mission runs: its supersteps, or the compiled graph")
    plan.add_argument("file", metavar="MISSION", help="a mission file, or a shipped mission's name")
    plan.add_argument(
        "--mermaid",
        action="store_true",
        help="print the mission's steps, dependencies and triggers as a Mermaid flowchart",
    )
    plan.add_argument("--param", action="append", default=[], metavar="NAME=VALUE", help="override a parameter")
    plan.set_defaults(func=_cmd_plan)

    schema = sub.add_parser("schema", help="print a JSON Schema (for editors: autocomplete and lint)")
    schema.add_argument("which", nargs="?", metavar="NAME", help=f"one of: {', '.join(SCHEMAS)}")
    schema.add_argument("--list", action="store_true", help="list the schemas and what each describes")
    schema.set_defaults(func=_cmd_schema)

    evaluate = sub.add_parser("eval", help="statistics on results files; reproduce the paper's statistics")
    eval_sub = evaluate.add_subparsers(dest="eval_command", metavar="EVAL_COMMAND", required=True)
    for name, text in (
        ("stats", "the paper's statistics pipeline on a results file (see: agentic-uav eval stats --help)"),
        ("paper", "recompute the paper's statistics from its published figures (agentic-uav eval paper --help)"),
        ("campaign", "run scenes through systems: records, metrics, statistics (agentic-uav eval campaign --help)"),
        ("paper-campaign", "the paper's 44-scene comparison, its results beside the paper's (--help)"),
        ("feedback", "operator feedback before/after on held-out scenes, a paired test (--help)"),
        ("tune", "tune the position controller's gains on gust flights; accept only if significantly better"),
    ):
        eval_sub.add_parser(name, help=text, add_help=False)  # listed here; parsed by _run_eval
    sub.add_parser("tools", help="list and describe the registered tools (agentic-uav tools --help)", add_help=False)
    sub.add_parser("mcp", help="serve the tools over MCP, stdio or HTTP (agentic-uav mcp --help)", add_help=False)
    sub.add_parser(
        "sim", help="the simulated quadrotor on MAVLink/UDP, like PX4 SITL (agentic-uav sim --help)", add_help=False
    )
    sub.add_parser("run", help="fly a mission end to end and write its report (agentic-uav run --help)", add_help=False)
    sub.add_parser("swarm", help="fly a mission with several UAVs (agentic-uav swarm run --help)", add_help=False)
    sub.add_parser("examples", help="list the shipped missions and scenes; copy them out to edit", add_help=False)
    sub.add_parser("console", help="the operator console in the browser: replay runs (agentic-uav console --help)",
                   add_help=False)  # fmt: skip
    sub.add_parser("memory", help="the fleet's memory: why, search, ingest, invalidate (agentic-uav memory --help)",
                   add_help=False)  # fmt: skip
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run one command; an error of ours is one line on stderr and exit 2 (bad input) or 1 (a failed run)."""
    try:
        return _main(list(sys.argv[1:] if argv is None else argv))
    except AgenticUAVError as exc:
        return report_error("agentic-uav", exc, sys.stderr)
    except BrokenPipeError:  # `agentic-uav tools list | head`: the reader left; not an error of ours
        sys.stderr.close()
        return 0


def _main(argv: list[str]) -> int:
    if len(argv) >= 2 and argv[0] == "eval" and argv[1] in EVAL_COMMANDS:
        return _run_eval(argv[1], argv[2:])
    if argv and argv[0] in DELEGATED:
        module = importlib.import_module(DELEGATED[argv[0]])
        code: int = module.main(argv[1:])
        return code
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    result: int = args.func(args)
    return result


if __name__ == "__main__":
    sys.exit(main())
