"""A campaign killed (SIGKILL) part-way and resumed ends with the same records as one run without interruption."""

from __future__ import annotations

import csv
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from evaluation.campaign import read_records
from evaluation.campaign.cli import main
from evaluation.campaign.records import TIMING_FIELDS
from tests.evaluation.campaign_scenes import write_scenes
from tests.waiting import wait_for

REPO = Path(__file__).resolve().parents[2]
SCENES = 8
SYSTEMS = ("yolo", "rules")


def complete_lines(path: Path) -> int:
    try:
        return path.read_bytes().count(b"\n")
    except FileNotFoundError:
        return 0


def csv_without_timing(path: Path) -> list[dict[str, str]]:
    with path.open(encoding="utf-8", newline="") as fh:
        return [{k: v for k, v in row.items() if k not in TIMING_FIELDS} for row in csv.DictReader(fh)]


@pytest.mark.slow
@pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="needs SIGKILL")
def test_a_killed_campaign_resumes_to_the_records_of_an_uninterrupted_one(tmp_path: Path) -> None:
    files = write_scenes(tmp_path, first_seed=400, persons=600, prefix="kill", count=SCENES)
    args = ["--scene-file", *files, "--systems", ",".join(SYSTEMS), "--frames", "60", "--quiet", "--no-stats"]
    killed, straight = tmp_path / "killed", tmp_path / "straight"
    command = [sys.executable, "-m", "agentic_core", "eval", "campaign", *args, "--out", str(killed)]
    process = subprocess.Popen(command, cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    results = killed / "results.jsonl"
    try:
        wait_for(
            lambda: complete_lines(results) >= len(SYSTEMS) or process.poll() is not None,
            240,  # inside pytest-timeout's 300 s, so the failure says what was awaited
            what=f"{len(SYSTEMS)} complete result lines (or the campaign's end)",
        )
        if process.poll() is not None:
            _, err = process.communicate()
            pytest.fail(f"the campaign ended before it could be killed: {err.decode(errors='replace')}")
        os.kill(process.pid, signal.SIGKILL)
    finally:
        process.kill()
        process.wait(timeout=60)
        if process.stderr is not None:
            process.stderr.close()
    done_before = complete_lines(results)
    assert process.returncode == -signal.SIGKILL
    assert len(SYSTEMS) <= done_before < SCENES * len(SYSTEMS)
    assert not (killed / "results.csv").exists()  # written only when the campaign completes

    assert main([*args, "--out", str(killed)]) == 0  # resume
    assert main([*args, "--out", str(straight)]) == 0  # uninterrupted
    resumed, uninterrupted = read_records(killed / "results.jsonl"), read_records(straight / "results.jsonl")
    assert len(resumed) == SCENES * len(SYSTEMS)
    assert [r.without_timing() for r in resumed] == [r.without_timing() for r in uninterrupted]
    assert csv_without_timing(killed / "results.csv") == csv_without_timing(straight / "results.csv")
    assert (killed / "metrics.json").is_file()
