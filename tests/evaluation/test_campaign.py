"""Campaigns end to end on small scenes: balanced records the stats read, reproducible records, parallel workers,
resuming, and refusing to resume a different campaign."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from evaluation.campaign import (
    CampaignError,
    CampaignPlan,
    DecisionRecord,
    EpisodeSettings,
    parse_systems,
    read_records,
    run_campaign,
    run_episode,
)
from evaluation.campaign.episode import perception_seed, point_of_interest
from evaluation.campaign.records import CSV_COLUMNS
from evaluation.stats import main as stats_main
from flight.sim.scene_gen import generate_scene
from flight.sim.scene_model import Scene

FRAMES = 45


def small_scenes(n: int) -> list[Scene]:
    """Small scenes (a walkway of 600 pilgrims, denser than the tent camp), every other one with a casualty."""
    return [
        generate_scene(200 + i, persons=600, casualties=i % 2, distractors=2, scene_id=f"small-{i + 1}")
        for i in range(n)
    ]


def plan(n: int = 4, systems: str = "yolo,rules", frames: int = FRAMES, seed: int = 0) -> CampaignPlan:
    return CampaignPlan(
        scenes=small_scenes(n), systems=parse_systems(systems, environ={}), settings=EpisodeSettings(frames=frames),
        seed=seed,
    )  # fmt: skip


def stripped(records: list[DecisionRecord]) -> list[dict[str, object]]:
    return [r.without_timing() for r in records]


@pytest.fixture(scope="module")
def campaign(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[DecisionRecord]]:
    out = tmp_path_factory.mktemp("campaign")
    result = run_campaign(plan(), out, quiet=True)
    return out, result.records


def test_every_scene_through_every_system_in_balanced_order(campaign: tuple[Path, list[DecisionRecord]]) -> None:
    out, records = campaign
    assert [(r.scene_id, r.system) for r in records] == [
        (f"small-{i}", s) for i in range(1, 5) for s in ("yolo", "rules")
    ]
    assert stripped(read_records(out / "results.jsonl")) == stripped(records)
    assert {p.name for p in out.iterdir()} == {
        "manifest.json", "results.jsonl", "results.csv", "metrics.md", "metrics.json", "progress.json",
    }  # fmt: skip
    header = (out / "results.csv").read_text(encoding="utf-8").splitlines()[0].split(",")
    assert tuple(header) == CSV_COLUMNS and "assessment" not in header


def test_records_hold_the_assessment_costs_and_ground_truth(campaign: tuple[Path, list[DecisionRecord]]) -> None:
    _, records = campaign
    for r in records:
        assert r.error is None and r.assessment is not None and r.frames == FRAMES
        assert r.n_actions == len(r.assessment.recommended_actions) and r.action_recommended == (r.n_actions > 0)
        assert r.contextual == (len(r.assessment.surrounding_features.strip()) > 50)
        assert r.person_detected == (r.assessment.persons_detected > 0)
        assert r.detection_tp + r.detection_fn == r.persons_in_view
        assert r.expected_severity == ("critical" if r.casualties else "none")
        assert r.casualty_in_view == bool(r.casualties)  # the camera hovers over the casualty
        assert r.time_to_intervention_s is None  # 1.5 s of frames: nobody has been still for 10 s yet
        assert r.assessments == 2 and r.sim_time_s == pytest.approx((FRAMES - 1) / 30)  # frame 29, final 44
    yolo = [r for r in records if r.system == "yolo"]
    assert all(not r.action_recommended and not r.contextual and r.severity == "none" for r in yolo)
    rules = [r for r in records if r.system == "rules"]
    assert all(r.action_recommended and r.contextual for r in rules)
    pairs = zip(yolo, rules, strict=True)
    assert all(y.persons_in_view == r.persons_in_view and y.seed == r.seed for y, r in pairs)  # one World Model


def test_the_stats_pipeline_reads_the_csv_and_the_jsonl_with_no_options(
    campaign: tuple[Path, list[DecisionRecord]], capsys: pytest.CaptureFixture[str]
) -> None:
    out, _ = campaign
    for name in ("results.csv", "results.jsonl"):
        assert stats_main([str(out / name), "--format", "json"]) == 0
        report = json.loads(capsys.readouterr().out)
        assert report["data_schema"] == "decision-records" and report["group_sizes"] == {"yolo": 4, "rules": 4}
        assert [c["column"] for c in report["continuous"]] == ["processing_time_s", "detection_confidence"]
        assert [c["column"] for c in report["categorical"]] == [
            "person_detected", "action_recommended", "contextual", "correct_severity", "missed_casualty", "false_alarm"
        ]  # fmt: skip


def test_a_record_is_the_same_whether_its_system_ran_alone_or_beside_others(
    campaign: tuple[Path, list[DecisionRecord]],
) -> None:
    _, records = campaign
    scene = small_scenes(2)[1]
    (alone,) = run_episode(scene, parse_systems("rules", environ={}), EpisodeSettings(frames=FRAMES), 0)
    beside = next(r for r in records if r.key == (scene.id, "rules"))
    assert alone.without_timing() == {**beside.without_timing(), "job_id": ""}  # a bare episode has no job
    assert alone.seed == perception_seed(0, scene.id) != perception_seed(1, scene.id)


def test_parallel_workers_give_the_records_of_one_worker(
    campaign: tuple[Path, list[DecisionRecord]], tmp_path: Path
) -> None:
    _, one_worker = campaign
    parallel = run_campaign(plan(), tmp_path / "parallel", workers=2, quiet=True)
    assert stripped(parallel.records) == stripped(one_worker)
    assert parallel.ran == 8 and parallel.resumed_from == 0


def test_a_complete_campaign_run_again_runs_nothing(campaign: tuple[Path, list[DecisionRecord]]) -> None:
    out, records = campaign
    again = run_campaign(plan(), out, quiet=True)
    assert again.ran == 0 and again.resumed_from == 8
    assert [r.model_dump() for r in again.records] == [r.model_dump() for r in records]  # timings included


def test_resume_skips_finished_records_and_cuts_a_torn_line(
    campaign: tuple[Path, list[DecisionRecord]], tmp_path: Path
) -> None:
    out, complete = campaign
    partial = tmp_path / "partial"
    first = run_campaign(plan(2), partial, quiet=True)  # the first two scenes only: a different plan...
    manifest = json.loads((out / "manifest.json").read_text())
    (partial / "manifest.json").write_text(json.dumps(manifest))  # ...so adopt the full campaign's manifest
    jsonl = partial / "results.jsonl"
    lines = jsonl.read_text().splitlines(keepends=True)
    jsonl.write_text("".join(lines[:3]) + lines[3][:40])  # three records whole, the fourth torn mid-line
    resumed = run_campaign(plan(), partial, quiet=True)
    assert resumed.resumed_from == 3 and resumed.ran == 5
    assert stripped(resumed.records) == stripped(complete)
    assert [r.processing_time_s for r in resumed.records[:3]] == [r.processing_time_s for r in first.records[:3]]


def test_a_different_campaign_is_refused_naming_the_setting(
    campaign: tuple[Path, list[DecisionRecord]], tmp_path: Path
) -> None:
    out, _ = campaign
    with pytest.raises(CampaignError, match=r"settings\.frames: 45 in the campaign directory, 60 now") as info:
        run_campaign(plan(frames=60), out, quiet=True)
    assert info.value.usage
    with pytest.raises(CampaignError, match=r"systems: 2 entries \[yolo, rules\] in the campaign directory, 1 "):
        run_campaign(plan(systems="rules"), out, quiet=True)
    with pytest.raises(CampaignError, match=r"^.*Differences: seed: 0 in the campaign directory, 7 now"):
        run_campaign(plan(seed=7), out, quiet=True)


def test_results_without_a_manifest_are_not_a_campaign(tmp_path: Path) -> None:
    (tmp_path / "results.jsonl").write_text('{"scene_id": "x"}\n')
    with pytest.raises(CampaignError, match=r"results\.jsonl exists without a manifest\.json"):
        run_campaign(plan(1), tmp_path, quiet=True)


def test_a_corrupt_record_names_its_line(campaign: tuple[Path, list[DecisionRecord]], tmp_path: Path) -> None:
    out, _ = campaign
    (tmp_path / "manifest.json").write_text((out / "manifest.json").read_text())
    lines = (out / "results.jsonl").read_text().splitlines(keepends=True)
    (tmp_path / "results.jsonl").write_text(lines[0] + '{"scene_id": "small-1"}\n' + lines[1])
    with pytest.raises(CampaignError, match=r"results.jsonl, line 2: not a DecisionRecord"):
        run_campaign(plan(), tmp_path, quiet=True)


def test_progress_goes_to_the_stream(tmp_path: Path) -> None:
    import io

    stream = io.StringIO()
    run_campaign(plan(1, frames=5), tmp_path, stream=stream)
    assert "campaign: 2/2 records (100%)" in stream.getvalue()


def test_the_point_of_interest() -> None:
    with_casualty, calm = small_scenes(2)[1], small_scenes(1)[0]
    casualty = with_casualty.actor(with_casualty.ground_truth.isolated[0])
    assert point_of_interest(with_casualty) == (casualty.position.north, casualty.position.east, "casualty P-C1")
    north, east, what = point_of_interest(calm)
    walkway = calm.zones[0].vertices()
    assert what == "crowd zone Z-walkway" and (north, east) == pytest.approx(tuple(walkway.mean(axis=0)))


def test_changed_code_is_named_as_such(campaign: tuple[Path, list[DecisionRecord]], tmp_path: Path) -> None:
    out, _ = campaign
    manifest = json.loads((out / "manifest.json").read_text())
    manifest["code_sha256"] = "0" * 64
    (tmp_path / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(
        CampaignError, match="code_sha256: the scene, detector, perception, reasoning, prompt or episode code"
    ):
        run_campaign(plan(), tmp_path, quiet=True)


def test_one_run_per_directory_at_a_time(tmp_path: Path) -> None:
    fcntl = pytest.importorskip("fcntl")
    import os

    fd = os.open(tmp_path, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # as a running campaign holds it
        with pytest.raises(CampaignError, match="another campaign is running in this directory"):
            run_campaign(plan(1), tmp_path, quiet=True)
    finally:
        os.close(fd)
    assert run_campaign(plan(1, frames=2), tmp_path, quiet=True).ran == 2
