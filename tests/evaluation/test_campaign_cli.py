"""``agentic-uav eval campaign``: the files it writes and says it wrote, bad input as exit 2 with a message, and
LLM systems against the local stand-in server (answers become records, failures become error records)."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import pytest

from agentic_core.cli import main as agentic_main
from evaluation.campaign import read_records
from evaluation.campaign.cli import main
from evaluation.campaign.metrics import compute_metrics
from tests.agentic_core.reasoning.llm.standin import StandIn, openai_completion, openai_error
from tests.evaluation.campaign_scenes import write_scenes

ANSWER = {
    "persons_detected": 12,
    "confidence": 0.84,
    "surrounding_features": "Pilgrims in white ihram walking north along the road; a first-aid post to the east.",
    "severity": "none",
    "recommended_actions": ["continue_patrol"],
    "rationale": "Normal flow.",
}


@pytest.fixture(scope="module")
def scene_files(tmp_path_factory: pytest.TempPathFactory) -> list[str]:
    return write_scenes(tmp_path_factory.mktemp("scenes"), first_seed=300, persons=600, prefix="cli")


@pytest.fixture
def standin() -> Iterator[StandIn]:
    with StandIn() as server:
        yield server


def test_a_campaign_writes_records_metrics_and_stats_and_says_where(
    scene_files: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "c"
    args = ["eval", "campaign", "--scene-file", *scene_files, "--frames", "20", "--out", str(out), "--quiet"]
    assert agentic_main(args) == 0
    captured = capsys.readouterr()
    assert captured.err == ""  # --quiet
    assert "| Metric | yolo | rules |" in captured.out
    assert f"campaign complete: 4 records (2 scenes × 2 systems; 4 run now) in {out}" in captured.out
    for name in ("manifest.json", "results.jsonl", "results.csv", "metrics.md", "metrics.json", "stats.md"):
        assert str(out / name) in captured.out and (out / name).is_file()
    assert {"stats.json", "stats.tex", "stats_rates.png", "stats_processing_time_s.png"} <= {
        p.name for p in out.iterdir()
    }
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["scene_source"] == {"kind": "files", "count": 2, "seed": None, "files": scene_files}
    assert manifest["settings"]["frames"] == 20 and [s["name"] for s in manifest["systems"]] == ["yolo", "rules"]
    assert set(manifest["versions"]) == {"agentic-uavs", "numpy", "scipy", "jsbsim", "pydantic", "python"}


def test_progress_and_the_refusal_to_mix_campaigns(
    scene_files: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = str(tmp_path / "c")
    base = ["--scene-file", *scene_files, "--systems", "rules", "--out", out, "--no-stats"]
    assert main([*base, "--frames", "10"]) == 0
    captured = capsys.readouterr()
    assert "campaign: 2/2 records (100%)" in captured.err and "stats:    skipped (--no-stats)" in captured.out
    assert main([*base, "--frames", "12"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("agentic-uav eval campaign: error: ") and "settings.frames: 10 in the campaign" in err
    assert "Traceback" not in err


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--systems", "yolo,fast"], "unknown system 'fast'"),
        (["--systems", "llm:nope:model"], "unknown provider 'nope'"),
        (["--systems", "llm"], "needs a model: write llm:PROVIDER:MODEL[@BASE_URL], or pass --llm SPEC"),
        (["--systems", "hybrid", "--llm", "gpt-4o"], "--llm 'gpt-4o': no provider before ':'"),
        (["--systems", "rules", "--llm", "openai:gpt-4o"], "openai needs an API key"),
        (["--systems", "rules,rules"], "are both named 'rules'"),
        (["--systems", "yolo:x"], "yolo takes no model"),
        (["--workers", "0"], "--workers must be at least 1, got 0"),
        (["--scenes", "0"], "--scenes must be at least 1, got 0"),
        (["--frames", "0"], "--frames must be at least 1"),
        (["--assess-every", "-1"], "--assess-every must be 0 or more"),
        (["--scene-file", "{missing}"], "cannot read the file"),
        (["--scene-file", "{bad}"], "bad.yaml"),
        (["--scene-file", "{scene}", "{scene}"], "each scene id must be unique; repeated: cli-1"),
        (["--scene-file", "{scene}", "--out", "{file}"], "cannot create the campaign directory"),
    ],
)
def test_bad_input_exits_2_with_a_message(
    args: list[str],
    message: str,
    scene_files: list[str],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    clean_env: None,
) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("id: bad\nactors: [{id: P-1, position: {north: 0}}]\n", encoding="utf-8")
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    names = {"{missing}": str(tmp_path / "missing.yaml"), "{bad}": str(bad), "{scene}": scene_files[0]}
    names["{file}"] = str(blocker)
    argv = [names.get(a, a) for a in args]
    if "--out" not in argv:
        argv += ["--out", str(tmp_path / "out")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not (tmp_path / "out" / "results.jsonl").exists()


def test_usage_errors_from_argparse_and_help(capsys: pytest.CaptureFixture[str]) -> None:
    assert main([]) == 2  # --out is required
    assert "--out" in capsys.readouterr().err
    assert main(["--workers", "two", "--out", "x"]) == 2
    assert agentic_main(["eval", "campaign", "--help"]) == 0
    assert "usage: agentic-uav eval campaign" in capsys.readouterr().out


def test_an_llm_system_answers_through_the_standin(
    scene_files: list[str], tmp_path: Path, standin: StandIn, clean_env: None, capsys: pytest.CaptureFixture[str]
) -> None:
    standin.script(*(openai_completion(json.dumps(ANSWER), prompt_tokens=700, completion_tokens=60) for _ in range(2)))
    spec = f"openai-compatible:stand-in-model@{standin.url}/v1"
    out = tmp_path / "llm"
    argv = ["--scene-file", *scene_files, "--systems", f"rules,llm:{spec}", "--frames", "10", "--assess-every", "0"]
    assert main([*argv, "--out", str(out), "--quiet", "--no-stats"]) == 0
    records = read_records(out / "results.jsonl")
    llm = [r for r in records if r.system == "llm:stand-in-model"]
    assert [r.scene_id for r in llm] == ["cli-1", "cli-2"] and len(standin.received) == 2
    for r in llm:
        assert (
            r.error is None and r.assessment is not None and r.assessment.model_dump(exclude={"subject_id"}) == ANSWER
        )
        assert (r.detection_confidence, r.person_detected, r.n_actions, r.contextual) == (0.84, True, 1, True)
        assert (r.llm_calls, r.prompt_tokens, r.completion_tokens, r.episode_tokens) == (1, 700, 60, 760)
        assert r.reasoner == "llm:stand-in-model" and r.assessments == 1
    prompt = standin.bodies()[0]["messages"][1]["content"]
    assert "Patrol the Hajj crowd" in prompt
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["systems"][1] == {"name": "llm:stand-in-model", "kind": "llm", "llm": spec}
    assert "| Metric | rules | llm:stand-in-model |" in capsys.readouterr().out


def test_a_failing_model_gives_error_records_not_a_crash(
    scene_files: list[str], tmp_path: Path, standin: StandIn, clean_env: None, capsys: pytest.CaptureFixture[str]
) -> None:
    standin.script(*(openai_error(400, "The model `stand-in` does not exist") for _ in range(2)))
    out = tmp_path / "failing"
    argv = ["--scene-file", *scene_files, "--systems", "yolo,gpt=llm", "--llm", f"openai-compatible:x@{standin.url}"]
    assert main([*argv, "--frames", "10", "--assess-every", "0", "--out", str(out), "--quiet"]) == 0
    records = read_records(out / "results.jsonl")
    failed = [r for r in records if r.system == "gpt"]
    assert len(failed) == 2
    for r in failed:
        assert r.assessment is None and r.error is not None and "does not exist" in r.error
        assert (r.person_detected, r.n_actions, r.contextual, r.detection_confidence) == (False, 0, False, None)
    captured = capsys.readouterr().out
    assert "| Records (n) | 2 | 2 (2 failed) |" in captured
    stats = (out / "stats.md").read_text()
    assert "records with an error (kept in every denominator): gpt: 2" in stats


def test_a_model_that_is_not_there_fails_each_record(tmp_path: Path, scene_files: list[str], clean_env: None) -> None:
    from evaluation.campaign import CampaignPlan, EpisodeSettings, SystemSpec, run_campaign
    from flight.sim.scene_file import load_scene

    # the worker builds the reasoner; a spec that cannot be built there (no key in its environment) is an error
    # record, as is every assessment of a model that cannot be reached
    system = SystemSpec(name="gpt", kind="llm", llm="openai:gpt-4o@https://api.openai.com/v1")
    plan = CampaignPlan(scenes=[load_scene(Path(scene_files[0]))], systems=[system], settings=EpisodeSettings(frames=5))
    (record,) = run_campaign(plan, tmp_path, quiet=True).records
    assert record.assessment is None and record.error is not None and "API key" in record.error


CRITICAL = {
    "persons_detected": 3,
    "confidence": 0.91,
    "surrounding_features": "An adult lying motionless on open ground, about 20 m from the pedestrian flow, no shade.",
    "severity": "critical",
    "recommended_actions": ["deploy_rescue_kit", "alert_medical_team"],
    "rationale": "Motionless and isolated: likely collapsed.",
}


def test_hybrid_asks_the_model_only_about_the_casualty(
    scene_files: list[str], tmp_path: Path, standin: StandIn, clean_env: None
) -> None:
    standin.script(openai_completion(json.dumps(CRITICAL)))
    out = tmp_path / "hybrid"
    llm = f"openai-compatible:stand-in@{standin.url}"
    argv = ["--scene-file", *scene_files, "--systems", "rules,hybrid", "--llm", llm, "--frames", "180"]
    assert main([*argv, "--assess-every", "0", "--out", str(out), "--quiet", "--no-stats"]) == 0
    records = {r.key: r for r in read_records(out / "results.jsonl")}
    calm, casualty = records[("cli-1", "hybrid")], records[("cli-2", "hybrid")]
    assert calm.llm_calls == 0 and not calm.escalated and calm.severity == records[("cli-1", "rules")].severity
    assert records[("cli-2", "rules")].severity == "high"  # still for 6 s: over half of still_s, not all of it
    assert casualty.escalated and casualty.llm_calls == 1 and casualty.severity == "critical"
    assert casualty.assessment is not None and casualty.assessment.rationale == CRITICAL["rationale"]
    assert len(standin.received) == 1
    metrics = compute_metrics(records.values())
    hybrid, rules = metrics.system("hybrid"), metrics.system("rules")
    assert hybrid.model_calls == 1 and hybrid.model_calls_saved == hybrid.assessments - 1 > 0
    assert rules.model_calls == 0 and rules.model_calls_saved is None
    row = next(line for line in (out / "metrics.md").read_text().splitlines() if line.startswith("| Model calls"))
    assert (
        row == f"| Model calls / assessments (saved) | 0 / {rules.assessments} | 1 / {hybrid.assessments} "
        f"({hybrid.assessments - 1} saved) |"
    )


def test_generated_scenes_by_count_and_seed(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "generated"
    assert main(["--scenes", "2", "--seed", "5", "--frames", "2", "--out", str(out), "--quiet", "--no-stats"]) == 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["scene_source"] == {"kind": "generated", "count": 2, "seed": 5, "files": []}
    assert [s["id"] for s in manifest["scenes"]] == ["campaign-5-01", "campaign-5-02"]
    assert [r.key for r in read_records(out / "results.jsonl")] == [
        ("campaign-5-01", "yolo"), ("campaign-5-01", "rules"), ("campaign-5-02", "yolo"), ("campaign-5-02", "rules"),
    ]  # fmt: skip


@pytest.mark.parametrize("spec", ["onnx:{missing}", "onnx:{not_onnx}"])
def test_an_unusable_detector_model_is_bad_input_before_any_scene_runs(
    spec: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A model that is missing or not ONNX exits 2 and writes nothing, as ``run --detector`` does."""
    not_onnx = tmp_path / "model.onnx"
    not_onnx.write_bytes(b"this is not a model")
    missing = tmp_path / "nowhere" / "model.onnx"
    detector = spec.format(missing=missing, not_onnx=not_onnx)
    out = tmp_path / "out"
    argv = ["--scenes", "1", "--frames", "5", "--detector", detector, "--out", str(out), "--quiet"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    path = str(missing if "missing" in spec else not_onnx)
    assert path in err and "Traceback" not in err
    assert not out.exists()
