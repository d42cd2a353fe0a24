"""Benchmark of campaign executors: episodes per minute with 1 and 2 workers, on local processes and on Dask.

Each executor runs the same campaign (``--scenes`` generated scenes through yolo and rules, ``--frames`` camera
frames each; one episode is one scene) into a fresh directory. Wall time counts everything the command would:
starting the workers (or the Dask cluster), the jobs, and writing the results. The table gives episodes per minute,
the speed-up over one worker of the same kind (goal: 2 workers ≥ 1.8×, on a machine with two free cores), the
start-up time of the executor alone (measured apart, with no job), and the executor's cost per episode against
``local`` with as many workers, start-up taken out (goal: < 5%).

Usage: ``python benchmarks/campaign_scaling.py [--scenes 16] [--frames 360] [--executors local:1,local:2,...]``.
Numbers from a machine other programs are using say little; the script prints the load average it saw.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from evaluation.campaign import CampaignPlan, EpisodeSettings, parse_systems, run_campaign
from evaluation.campaign.executors import open_executor, parse_executor
from flight.sim.scene_gen import generate_scenes

DEFAULT = "local:1,local:2,dask-local:1,dask-local:2"


def start_up_s(text: str) -> float:
    """Seconds to open and close the executor with no job (0 for local: its processes start with the first job)."""
    spec = parse_executor(text)
    if spec.kind == "local":
        return 0.0
    start = time.perf_counter()
    with open_executor(spec, jobs=1, preload="evaluation.campaign.jobs"):
        pass
    return time.perf_counter() - start


def run(text: str, plan: CampaignPlan) -> float:
    with tempfile.TemporaryDirectory() as out:
        start = time.perf_counter()
        run_campaign(plan, Path(out), executor=text, quiet=True)
        return time.perf_counter() - start


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenes", type=int, default=16)
    parser.add_argument("--frames", type=int, default=360)
    parser.add_argument("--executors", default=DEFAULT)
    args = parser.parse_args(argv)
    plan = CampaignPlan(
        scenes=generate_scenes(args.scenes, seed=0),
        systems=parse_systems("yolo,rules", environ={}),
        settings=EpisodeSettings(frames=args.frames),
    )
    executors = [e.strip() for e in args.executors.split(",") if e.strip()]
    print(f"campaign scaling: {args.scenes} episodes (yolo, rules; {args.frames} frames), {os.cpu_count()} CPUs")
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    walls: dict[str, float] = {}
    starts: dict[str, float] = {}
    for text in executors:
        starts[text] = start_up_s(text)
        walls[text] = run(text, plan)
    header = (
        f"{'executor':<16}{'wall s':>9}{'episodes/min':>14}{'vs 1 worker':>13}{'start-up s':>12}{'cost/episode':>14}"
    )
    print(header)
    for text in executors:
        spec = parse_executor(text)
        rate = 60.0 * args.scenes / walls[text]
        one = f"{spec.kind}:1"
        speed = f"{walls[one] / walls[text]:.2f}×" if one in walls else "–"
        local = f"local:{spec.workers}"
        cost = "–"
        if spec.kind != "local" and local in walls:
            extra = (walls[text] - starts[text] - walls[local]) / walls[local]
            cost = f"{100.0 * extra:+.1f}%"
        print(f"{text:<16}{walls[text]:>9.2f}{rate:>14.1f}{speed:>13}{starts[text]:>12.2f}{cost:>14}")
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
