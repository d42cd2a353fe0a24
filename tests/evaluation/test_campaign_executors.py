"""``--executor``: what it accepts and refuses, jobs addressed by content, the job order's recorded seed, and a
resumed campaign that skips exactly the records it has."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from agentic_core.contracts.extras import MissingExtra
from evaluation.campaign import CampaignPlan, EpisodeSettings, parse_systems, read_records, run_campaign
from evaluation.campaign.cli import main
from evaluation.campaign.episode import derive_seed
from evaluation.campaign.executors import ExecutorSpecError, open_executor, parse_executor
from evaluation.campaign.jobs import job_id, shuffled
from evaluation.campaign.manifest import scene_digest
from evaluation.campaign.records import append_record
from flight.sim.scene_gen import generate_scene
from flight.sim.scene_model import Scene


def scenes(n: int) -> list[Scene]:
    return [generate_scene(500 + i, persons=60, casualties=i % 2, distractors=0, scene_id=f"ex-{i}") for i in range(n)]


@pytest.mark.parametrize(
    ("text", "kind", "workers", "address"),
    [
        ("local:1", "local", 1, None),
        (" local:3 ", "local", 3, None),
        ("dask-local:2", "dask-local", 2, None),
        ("dask://127.0.0.1:8786", "dask", None, "127.0.0.1:8786"),
        ("dask://scheduler.lab:1", "dask", None, "scheduler.lab:1"),
    ],
)
def test_executor_specs(text: str, kind: str, workers: int | None, address: str | None) -> None:
    spec = parse_executor(text)
    assert (spec.kind, spec.workers, spec.address) == (kind, workers, address)
    assert parse_executor(spec.text) == spec


@pytest.mark.parametrize(
    "text",
    ["", "local", "local:0", "local:-1", "local:x", "local:2000", "dask-local:0", "dask://", "dask://host",
     "dask://host:0", "dask://host:70000", "dask://a b:1", "ray:2", "tcp://127.0.0.1:8786", "local:1;rm -rf /"],
)  # fmt: skip
def test_bad_executor_specs_are_input_errors_naming_the_option(text: str) -> None:
    with pytest.raises(ExecutorSpecError, match="--executor") as caught:
        parse_executor(text)
    assert caught.value.exit_status == 2


def test_a_bad_executor_on_the_command_line_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--scenes", "1", "--executor", "ray:2", "--out", str(tmp_path / "c")]) == 2
    err = capsys.readouterr().err
    assert "'ray:2' is not an executor; expected local:K, dask-local:K or dask://HOST:PORT" in err
    assert "Traceback" not in err and not (tmp_path / "c").exists()
    assert main(["--scenes", "1", "--executor", "local:2", "--workers", "2", "--out", str(tmp_path / "c")]) == 2
    assert "give one of them" in capsys.readouterr().err


def test_a_missing_dask_is_an_error_naming_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed now raises ImportError
    opened = open_executor(parse_executor("dask-local:1"), jobs=1)
    with pytest.raises(MissingExtra, match=r"pip install 'agentic-uavs\[distributed\]'") as caught, opened:
        pass
    assert caught.value.extra == "distributed" and caught.value.exit_status == 2


def test_no_scheduler_at_the_address_is_a_clear_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    import socket

    from evaluation.campaign import executors

    monkeypatch.setattr(executors, "CONNECT_TIMEOUT_S", 1.0)
    with socket.socket() as sock:  # a free port with nobody listening
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    argv = ["--scenes", "1", "--frames", "2", "--executor", f"dask://127.0.0.1:{port}", "--quiet", "--no-stats"]
    assert main([*argv, "--out", str(tmp_path / "c")]) == 2
    err = capsys.readouterr().err
    assert f"no Dask scheduler answers at 127.0.0.1:{port}" in err and "Traceback" not in err


def test_a_job_id_changes_with_everything_that_decides_the_record() -> None:
    scene = scenes(1)[0]
    rules, yolo = parse_systems("rules,yolo", environ={})
    base = job_id(scene_digest(scene), rules, 0, EpisodeSettings())
    other_scene = generate_scene(999, persons=60, scene_id=scene.id)  # same id, other content
    variants = [
        job_id(scene_digest(other_scene), rules, 0, EpisodeSettings()),
        job_id(scene_digest(scene), yolo, 0, EpisodeSettings()),
        job_id(scene_digest(scene), rules, 1, EpisodeSettings()),
        job_id(scene_digest(scene), rules, 0, EpisodeSettings(frames=30)),
        job_id(scene_digest(scene), parse_systems("llm:ollama:a@http://127.0.0.1:1", environ={})[0], 0,
               EpisodeSettings()),
    ]  # fmt: skip
    assert len({base, *variants}) == 1 + len(variants)
    assert base == job_id(scene_digest(scene.model_copy(deep=True)), rules, 0, EpisodeSettings())


def test_the_job_order_is_shuffled_by_the_seed_the_manifest_records(tmp_path: Path) -> None:
    plan = CampaignPlan(
        scenes=scenes(6), systems=parse_systems("yolo", environ={}), settings=EpisodeSettings(frames=2), seed=4
    )
    run_campaign(plan, tmp_path, quiet=True)
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    assert manifest["job_order_seed"] == derive_seed(4, "job-order") and manifest["executor"] == "local:1"
    # local:1 runs the jobs in the shuffled order: the file before the final rewrite would show it; the rewrite
    # puts them in the balanced order
    assert [r.scene_id for r in read_records(tmp_path / "results.jsonl")] == [f"ex-{i}" for i in range(6)]
    order = shuffled([f"ex-{i}" for i in range(6)], manifest["job_order_seed"])
    assert order != sorted(order)  # this seed does move the scenes


def test_a_resumed_campaign_skips_exactly_the_records_whose_job_id_it_has(tmp_path: Path) -> None:
    plan = CampaignPlan(scenes=scenes(3), systems=parse_systems("yolo,rules", environ={}),
                        settings=EpisodeSettings(frames=2))  # fmt: skip
    first = run_campaign(plan, tmp_path / "a", quiet=True).records
    target = tmp_path / "b"
    target.mkdir()
    (target / "manifest.json").write_bytes((tmp_path / "a" / "manifest.json").read_bytes())
    kept = first[1]
    append_record(target / "results.jsonl", kept)
    forged = first[2].model_copy(update={"job_id": "0" * 64})  # a record of no job of this campaign
    append_record(target / "results.jsonl", forged)
    result = run_campaign(plan, target, quiet=True)
    assert result.resumed_from == 1 and result.ran == 5
    assert [r.job_id for r in result.records] == [r.job_id for r in first]
    assert result.records[1] == kept
