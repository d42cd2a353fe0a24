"""A campaign of deterministic systems gives the same records on a Dask cluster as on this process: a scheduler
and two workers started as separate processes on 127.0.0.1 (ports chosen by the scheduler, no dashboard), the
same campaign run through ``dask://`` and locally, and the results compared byte for byte after sorting, the
wall-clock columns (:data:`~evaluation.campaign.records.TIMING_FIELDS`) left out. A ``dask-local`` cluster gives
them too (one scene, one worker: starting its process is most of the cost)."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from evaluation.campaign.cli import main
from evaluation.campaign.records import TIMING_FIELDS
from tests.evaluation.campaign_scenes import write_scenes
from tests.waiting import wait_for

pytest.importorskip("distributed")
REPO = Path(__file__).resolve().parents[2]
DASK = Path(sys.executable).with_name("dask")


def sorted_jsonl(path: Path) -> list[str]:
    lines = []
    for line in path.read_text(encoding="utf-8").splitlines():
        data = {k: v for k, v in json.loads(line).items() if k not in TIMING_FIELDS}
        lines.append(json.dumps(data, sort_keys=True))
    return sorted(lines)


def sorted_csv(path: Path) -> list[str]:
    with path.open(encoding="utf-8", newline="") as fh:
        rows = [{k: v for k, v in row.items() if k not in TIMING_FIELDS} for row in csv.DictReader(fh)]
    return sorted(json.dumps(row) for row in rows)


def stop(processes: list[subprocess.Popen[bytes]]) -> None:
    """SIGINT to every process at once (Dask's quickest clean exit), then SIGKILL to any still running 5 s
    later."""
    for process in processes:
        if process.poll() is None:
            process.send_signal(signal.SIGINT)
    for process in processes:
        try:
            process.wait(timeout=5)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait(timeout=5)


@pytest.fixture
def dask_cluster(tmp_path: Path) -> Iterator[str]:
    """``dask scheduler`` and two ``dask worker`` processes on 127.0.0.1 (each importing the campaign code as it
    starts); yields the scheduler's address as soon as it has one, the workers still starting."""
    if not DASK.exists():
        pytest.skip(f"no dask command beside {sys.executable}")
    scheduler_file = tmp_path / "scheduler.json"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]).rstrip(":")}
    common = ["--no-dashboard", "--scheduler-file", str(scheduler_file)]
    logs = tmp_path / "dask.log"
    processes: list[subprocess.Popen[bytes]] = []
    scheduler = [str(DASK), "scheduler", "--host", "127.0.0.1", "--port", "0", *common]
    worker = [str(DASK), "worker", "--host", "127.0.0.1", "--nthreads", "1", "--no-nanny", *common]
    worker += ["--preload", "evaluation.campaign.jobs"]
    try:
        with logs.open("ab") as log:
            processes.append(subprocess.Popen(scheduler, cwd=tmp_path, env=env, stdout=log, stderr=log))
            wait_for(lambda: scheduler_file.exists() and scheduler_file.stat().st_size > 0, 20, what="the scheduler")
            for _ in range(2):
                processes.append(subprocess.Popen(worker, cwd=tmp_path, env=env, stdout=log, stderr=log))
        address = json.loads(scheduler_file.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:")
        yield address.removeprefix("tcp://")
    finally:
        stop(processes)
    assert all(p.poll() is not None for p in processes)


def wait_for_workers(address: str, count: int) -> None:
    from distributed import Client

    with Client(f"tcp://{address}", timeout="20s") as client:
        client.wait_for_workers(count, timeout=40)
        assert all(w.startswith("tcp://127.0.0.1:") for w in client.nthreads())


@pytest.fixture(scope="module")
def scene_files(tmp_path_factory: pytest.TempPathFactory) -> list[str]:
    return write_scenes(tmp_path_factory.mktemp("dask-scenes"), first_seed=700, persons=200, prefix="dask")


def campaign(scene_files: list[str], out: Path, *executor: str) -> Path:
    argv = ["--scene-file", *scene_files, "--systems", "rules,yolo", "--frames", "45", "--assess-every", "15"]
    assert main([*argv, *executor, "--out", str(out), "--quiet", "--no-stats"]) == 0
    return out


@pytest.mark.slow
def test_a_dask_cluster_gives_the_records_of_a_local_run(
    dask_cluster: str, scene_files: list[str], tmp_path: Path
) -> None:
    local = campaign(scene_files, tmp_path / "local")  # while the workers start
    wait_for_workers(dask_cluster, 2)
    distributed = campaign(scene_files, tmp_path / "dask", "--executor", f"dask://{dask_cluster}")
    assert sorted_jsonl(distributed / "results.jsonl") == sorted_jsonl(local / "results.jsonl")
    assert sorted_csv(distributed / "results.csv") == sorted_csv(local / "results.csv")
    assert len(sorted_jsonl(local / "results.jsonl")) == 4
    manifest = json.loads((distributed / "manifest.json").read_text())
    assert manifest["executor"] == f"dask://{dask_cluster}"


def test_a_dask_local_cluster_gives_them_too(scene_files: list[str], tmp_path: Path) -> None:
    distributed = campaign(scene_files[:1], tmp_path / "dask-local", "--executor", "dask-local:1")
    local = campaign(scene_files[:1], tmp_path / "local")
    assert sorted_jsonl(distributed / "results.jsonl") == sorted_jsonl(local / "results.jsonl")
