"""``agentic-uav eval paper-campaign``: the paper's comparison as one command, its results beside the paper's.

It runs the paper's campaign — 44 generated scenes (seed 0) through the YOLO baseline, the rule reasoner, the model
alone and the hybrid (``--llm`` names the model) — with ``eval campaign``'s statistics and plots, then writes
``paper_comparison.md``: the paper's Table 2 figures (from :mod:`evaluation.paper`'s ``figures.json``) in columns
beside this campaign's metrics. Every ``eval campaign`` option after ``--`` is passed on (``--executor``,
``--budget-usd``, ``--replay``, ...); run it again to resume.

Example::

    agentic-uav eval paper-campaign --llm ollama:gemma3:4b --out runs/paper -- --executor local:2
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TextIO

from agentic_core.contracts.errors import AgenticUAVError, report_error

PROG = "agentic-uav eval paper-campaign"
SYSTEMS = "yolo,rules,llm,hybrid"
PAPER_GROUPS = ("yolo", "gemma", "gpt4")
COMPARISON = "paper_comparison.md"


def main(argv: Sequence[str] | None = None, stdout: TextIO | None = None, stderr: TextIO | None = None) -> int:
    """Entry point: ``main(["--llm", "ollama:gemma3:4b", "--out", "runs/paper"])`` returns the exit status."""
    out, err = stdout or sys.stdout, stderr or sys.stderr
    args_list = list(sys.argv[1:] if argv is None else argv)
    own, passed = (
        (args_list[: args_list.index("--")], args_list[args_list.index("--") + 1 :])
        if "--" in args_list
        else (args_list, [])
    )
    parser = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n\n")[0])
    parser.add_argument("--llm", required=True, metavar="SPEC", help="the model of 'llm' and 'hybrid'")
    parser.add_argument("--out", type=Path, default=Path("runs/paper-campaign"), metavar="DIR")
    parser.add_argument("--scenes", type=int, default=44, metavar="N", help="generated scenes (default 44)")
    try:
        args = parser.parse_args(own)
    except SystemExit as exc:
        return int(exc.code) if isinstance(exc.code, int) else 2
    from .cli import main as campaign_main

    argv_campaign = ["--scenes", str(args.scenes), "--seed", "0", "--systems", SYSTEMS, "--llm", args.llm]
    code = campaign_main([*argv_campaign, *passed, "--out", str(args.out)], stdout=out, stderr=err)
    if code != 0:
        return code
    try:
        path = write_comparison(args.out)
    except AgenticUAVError as exc:
        return report_error(PROG, exc, err)
    print(f"  paper:    {path}", file=out)
    return 0


def write_comparison(out_dir: Path) -> Path:
    """Write ``paper_comparison.md`` into ``out_dir`` from its ``metrics.json`` and the paper's figures."""
    from evaluation.paper.figures import load_figures

    from .metrics import CampaignMetrics

    metrics = CampaignMetrics.model_validate_json((out_dir / "metrics.json").read_text(encoding="utf-8"))
    figures = load_figures()
    names = [figures.groups[g].short for g in PAPER_GROUPS]
    header = ["Metric", *(f"paper: {n}" for n in names), *(f"here: {s.system}" for s in metrics.systems)]

    def paper(prefix: str, percent: bool) -> list[str]:
        cells = []
        for group in PAPER_GROUPS:
            value = figures.value(f"{prefix}.{group}")
            cells.append(f"{100 * value:.1f}%" if percent else f"{value:.3f}")
        return cells

    def time_cell(mean: float | None, sd: float | None) -> str:
        return "–" if mean is None else f"{mean:.3g} ± {sd or 0.0:.2g} s"

    def pct(value: float | None) -> str:
        return "–" if value is None else f"{100 * value:.1f}%"

    rows = [
        ["Processing time (mean ± SD)"]
        + [time_cell(figures.value(f"pt.{g}.mean"), figures.value(f"pt.{g}.sd")) for g in PAPER_GROUPS]
        + [time_cell(s.processing_time_mean_s, s.processing_time_sd_s) for s in metrics.systems],
        ["Detection confidence", *paper("conf", False)]
        + [
            "–" if s.detection_confidence_mean is None else f"{s.detection_confidence_mean:.3f}"
            for s in metrics.systems
        ],
        ["Persons detected", *(f"{100 * figures.value(f'persons.{g}.rate'):.1f}%" for g in PAPER_GROUPS)]
        + [pct(s.persons_detected_rate) for s in metrics.systems],
        ["Action Recommendation Rate", *paper("arr", True)]
        + [pct(s.action_recommendation_rate) for s in metrics.systems],
        ["Contextual Analysis Rate", *paper("car", True)] + [pct(s.contextual_analysis_rate) for s in metrics.systems],
    ]
    lines = [
        "# This campaign beside the paper",
        "",
        f"The paper: {figures.paper.title} ({figures.paper.authors}), Table 2 (n = 44 per system). Here: "
        f"{metrics.systems[0].n} scenes per system; the statistics and plots are in stats.md and stats_*.png.",
        "",
        "| " + " | ".join(header) + " |",
        "|" + "---|" * len(header),
        *("| " + " | ".join(row) + " |" for row in rows),
        "",
    ]
    path = out_dir / COMPARISON
    path.write_text("\n".join(lines), encoding="utf-8")
    return path


__all__ = ["COMPARISON", "SYSTEMS", "main", "write_comparison"]
