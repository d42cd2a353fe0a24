"""``agentic-uav eval campaign``: run scenes through systems, then the metrics and the paper's statistics.

Example (ten generated scenes, the baseline and the rule reasoner, two worker processes)::

    agentic-uav eval campaign --scenes 10 --seed 0 --systems yolo,rules --executor local:2 --out runs/campaign-10

``--executor dask-local:K`` runs the jobs on a Dask cluster started on 127.0.0.1, ``--executor dask://HOST:PORT``
on an existing one (the extra ``distributed``). A model campaign keeps its model's answers in
``model_cache.jsonl``; ``--replay DIR`` re-scores DIR's campaign from them with no model, and ``--budget-calls``,
``--budget-tokens`` and ``--budget-usd`` (with ``--price``) stop it cleanly when spent.

Run the same command again after an interruption to resume; the directory then also holds ``stats.md``,
``stats.json``, ``stats.tex`` and the plots (``stats_*.png``) of :mod:`evaluation.stats` on ``results.jsonl``.

Exit status: 0 when the campaign is complete, 2 on bad input (an unknown system, a bad LLM spec, an unreadable
scene file, ``--workers 0``, a bad ``--executor``, a directory holding a different campaign), 1 when a job fails,
3 when the budget stopped it (what finished is kept; run again with a larger budget), 130 when interrupted.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, TextIO

from agentic_core.contracts.errors import AgenticUAVError, InputError, report_error

from .model_options import add_model_arguments

if TYPE_CHECKING:
    from flight.sim.scene_model import Scene

    from .manifest import SceneSource

PROG = "agentic-uav eval campaign"


def configure_parser(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """Add this command's arguments to ``parser``."""
    scenes = parser.add_mutually_exclusive_group()
    scenes.add_argument(
        "--scenes", type=int, metavar="N", help="generate N scenes from --seed (default 44, as in the paper)"
    )
    scenes.add_argument(
        "--scene-file", action="extend", nargs="+", metavar="FILE", help="scene files (YAML/JSON) instead"
    )
    parser.add_argument("--seed", type=int, default=0, metavar="S", help="campaign seed (default 0)")
    parser.add_argument(
        "--systems",
        default="yolo,rules",
        metavar="LIST",
        help="comma-separated [NAME=]KIND[:LLM_SPEC]: yolo, rules, hybrid, llm, llm:PROVIDER:MODEL[@URL] "
        "(default yolo,rules)",
    )
    parser.add_argument("--llm", metavar="SPEC", help="the model of a bare 'llm' or 'hybrid' (PROVIDER:MODEL[@URL])")
    parser.add_argument(
        "--executor",
        metavar="SPEC",
        help="where jobs run: local:K (K processes here), dask-local:K (a Dask cluster on 127.0.0.1), "
        "dask://HOST:PORT (an existing Dask scheduler); default local:1",
    )
    parser.add_argument("--workers", type=int, metavar="K", help="the same as --executor local:K")
    parser.add_argument("--frames", type=int, default=360, metavar="N", help="camera frames at 30 Hz (default 360)")
    parser.add_argument(
        "--assess-every", type=int, default=30, metavar="N", help="frames between assessments; 0: final only (30)"
    )
    parser.add_argument("--altitude", type=float, default=30.0, metavar="M", help="hover height, metres (default 30)")
    parser.add_argument(
        "--detector", default="sim", metavar="sim|ours|onnx:PATH",
        help="sim: the statistical detector (default, fast); ours or onnx:PATH: a real detector on rendered frames",
    )  # fmt: skip
    parser.add_argument("--out", type=Path, required=True, metavar="DIR", help="the campaign directory")
    parser.add_argument("--no-stats", action="store_true", help="skip the statistics report")
    stop = parser.add_argument_group("stopping when the answer is known")
    stop.add_argument(
        "--stop-at-width",
        type=float,
        metavar="W",
        help="start no new scene once the 95%% interval of the primary comparison is at most W wide",
    )
    stop.add_argument(
        "--stop-compare",
        metavar="T,B",
        help="the primary comparison: system T minus system B, paired by scene (default: the second system "
        "minus the first)",
    )
    stop.add_argument(
        "--stop-metric",
        default="detection_confidence",
        metavar="FIELD",
        help="the numeric record field compared (default detection_confidence)",
    )
    stop.add_argument(
        "--stop-min-scenes", type=int, default=5, metavar="N", help="never stop before N paired scenes (default 5)"
    )
    add_model_arguments(parser)
    parser.add_argument("--quiet", action="store_true", help="no progress display")
    return parser


def main(argv: Sequence[str] | None = None, stdout: TextIO | None = None, stderr: TextIO | None = None) -> int:
    """Entry point: ``main(["--scenes", "4", "--out", "runs/c"])`` returns the exit status."""
    out = stdout or sys.stdout
    err = stderr or sys.stderr
    parser = configure_parser(argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n\n")[0]))
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse: --help (0) and usage errors (2), its message already printed
        return int(exc.code) if isinstance(exc.code, int) else 2
    try:
        return _run(args, out, err)
    except AgenticUAVError as exc:
        return report_error(PROG, exc, err)


class _UsageError(InputError):
    pass


def _run(args: argparse.Namespace, out: TextIO, err: TextIO) -> int:
    from pydantic import ValidationError

    from agentic_core.contracts.errors import InputError
    from agentic_core.run.detector_choice import camera_spec, load_detector, parse_detector

    from .early_stop import parse_stop_rule
    from .episode import EpisodeSettings
    from .executors import ExecutorSpecError, parse_executor
    from .model_options import model_options
    from .runner import BudgetSpent, CampaignError, CampaignPlan, run_campaign
    from .systems import SystemSpecError, parse_systems

    if args.workers is not None and args.workers < 1:
        raise _UsageError(f"--workers must be at least 1, got {args.workers}")
    if args.workers is not None and args.executor is not None:
        raise _UsageError("--workers K is --executor local:K: give one of them")
    try:
        executor = parse_executor(args.executor or f"local:{args.workers or 1}")
    except ExecutorSpecError as exc:
        raise _UsageError(str(exc)) from None
    if args.seed < 0:
        raise _UsageError(f"--seed must be 0 or more, got {args.seed}")
    if args.frames < 1:
        raise _UsageError(f"--frames must be at least 1, got {args.frames}")
    if args.assess_every < 0:
        raise _UsageError(f"--assess-every must be 0 or more, got {args.assess_every}")
    if not 2.0 < args.altitude <= 500.0:
        raise _UsageError(f"--altitude must be above 2 and at most 500 m, got {args.altitude:g}")
    try:
        systems = parse_systems(args.systems, llm=args.llm)
        if args.llm:
            parse_systems(f"llm:{args.llm}")  # a bad --llm is an error even when no system uses it
    except SystemSpecError as exc:
        raise _UsageError(str(exc)) from None
    models, budget = model_options(args, systems)
    stop = parse_stop_rule(
        args.stop_at_width, args.stop_compare, args.stop_metric, args.stop_min_scenes, [s.name for s in systems]
    )
    scenes, source = _scenes(args)
    try:
        detector = parse_detector(args.detector)
        load_detector(detector)  # a missing or unusable model is bad input, found before any scene runs
    except InputError as exc:
        raise _UsageError(str(exc)) from None
    settings = EpisodeSettings(
        frames=args.frames, assess_every=args.assess_every, altitude_m=args.altitude, detector=detector,
        camera=camera_spec(detector),
    )  # fmt: skip
    try:
        plan = CampaignPlan(scenes=scenes, systems=systems, settings=settings, seed=args.seed, scene_source=source)
    except ValidationError as exc:
        raise _UsageError(str(exc.errors()[0]["msg"]).removeprefix("Value error, ")) from None
    try:
        result = run_campaign(
            plan, args.out, executor=executor, quiet=args.quiet, stream=err, models=models, budget=budget,
            replay=args.replay, stop=stop,
        )  # fmt: skip
    except BudgetSpent as exc:
        print(f"{PROG}: stopped: {exc}", file=err)
        return 3
    except CampaignError as exc:
        print(f"{PROG}: error: {exc}", file=err)
        return 2 if exc.usage else 1
    except KeyboardInterrupt:
        print(f"\n{PROG}: interrupted; run the same command again to resume in {args.out}", file=err)
        return 130
    stats_line = "skipped (--no-stats)" if args.no_stats else _stats(args.out, len(systems))
    table = result.metrics.to_markdown().split("\n\nRates count")[0]
    print(table, file=out)
    n_scenes, n_systems = len(result.records) // len(systems), len(systems)
    resumed = f", {result.resumed_from} from an earlier run" if result.resumed_from else ""
    if result.stopped_early:
        print(f"\nstopped early, {n_scenes} of {len(scenes)} scenes: {result.stopped_early}", file=out)
    print(
        f"\ncampaign complete: {len(result.records)} records ({n_scenes} scenes × {n_systems} systems; "
        f"{result.ran} run now{resumed}) in {args.out}",
        file=out,
    )
    files = result.files
    print(f"  manifest: {files['manifest']}", file=out)
    print(f"  records:  {files['results_jsonl']}, {files['results_csv']}", file=out)
    print(f"  metrics:  {files['metrics_md']}, {files['metrics_json']}", file=out)
    print(f"  stats:    {stats_line}", file=out)
    return 0


def _scenes(args: argparse.Namespace) -> tuple[list[Scene], SceneSource]:
    from flight.sim.scene_file import SceneFileError, load_scene
    from flight.sim.scene_gen import generate_scenes

    from .manifest import SceneSource

    if args.scene_file:
        scenes = []
        for name in args.scene_file:
            try:
                scenes.append(load_scene(Path(name)))
            except SceneFileError as exc:
                raise _UsageError(str(exc)) from None
        return scenes, SceneSource(kind="files", count=len(scenes), files=list(args.scene_file))
    count = 44 if args.scenes is None else args.scenes
    if count < 1:
        raise _UsageError(f"--scenes must be at least 1, got {count}")
    if count > 10_000:
        raise _UsageError(f"--scenes is at most 10000, got {count}")
    scenes = generate_scenes(count, seed=args.seed)
    return scenes, SceneSource(kind="generated", count=count, seed=args.seed)


def _stats(out_dir: Path, n_systems: int) -> str:
    """The paper's statistics on the campaign's records, into ``out_dir``; a line saying what was written."""
    if n_systems < 2:
        return "skipped (the statistics compare two or more systems)"
    from evaluation.stats.dataset import load_dataset
    from evaluation.stats.errors import InputError
    from evaluation.stats.pipeline import analyze_dataset
    from evaluation.stats.plots import write_plots

    try:
        dataset = load_dataset(out_dir / "results.jsonl")
        report = analyze_dataset(dataset)
    except InputError as exc:
        return f"skipped ({exc})"
    except Exception as exc:  # the campaign is complete and recorded; a failed report must not hide that
        return f"failed ({type(exc).__name__}: {exc}); run: agentic-uav eval stats {out_dir / 'results.jsonl'}"
    try:
        (out_dir / "stats.md").write_text(report.to_markdown(), encoding="utf-8")
        (out_dir / "stats.tex").write_text(report.to_latex(), encoding="utf-8")
        (out_dir / "stats.json").write_text(report.to_json() + "\n", encoding="utf-8")
    except OSError as exc:
        return f"not written ({exc.strerror or exc})"
    written = f"{out_dir / 'stats.md'}, {out_dir / 'stats.json'}, {out_dir / 'stats.tex'}"
    try:
        plots = write_plots(report, out_dir, dataset)
    except Exception as exc:  # a plotting failure leaves the report itself standing
        return f"{written}; plots failed ({type(exc).__name__}: {exc})"
    return f"{written}; plots: {', '.join(p.name for p in plots)}"


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
