"""Affordable model campaigns against the local stand-in model server: a campaign replayed from its response cache
with the server stopped gives the same results; a server that always answers 429 makes the endpoint's limit halve
and the campaign end with error records, not hang; a budget of one call stops the campaign cleanly, what finished
kept, and a larger budget goes on from there."""

from __future__ import annotations

import csv
import hashlib
import json
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from evaluation.campaign import CampaignPlan, EpisodeSettings, parse_systems, read_records, run_campaign
from evaluation.campaign.budget import Budget
from evaluation.campaign.cli import main
from evaluation.campaign.model_calls import EndpointLimiter, ModelSettings, limiter_for
from evaluation.campaign.records import TIMING_FIELDS
from evaluation.campaign.runner import MODEL_CACHE
from flight.sim.scene_gen import generate_scene
from tests.agentic_core.reasoning.llm.standin import Reply, StandIn, openai_completion, openai_error
from tests.evaluation.campaign_scenes import write_scenes


def answer(path: str, body: Any) -> Reply:
    """A stand-in model whose answer depends on the request (so a replay that served the wrong one would show)."""
    digest = hashlib.sha256(json.dumps(body, sort_keys=True).encode()).digest()
    content = {
        "persons_detected": digest[0] % 40,
        "confidence": round(0.5 + digest[1] / 512, 3),
        "surrounding_features": "Pilgrims walking along the road between the tents, a water point to the north-east.",
        "severity": ("none", "low", "high")[digest[2] % 3],
        "recommended_actions": ["continue_patrol"] if digest[3] % 2 else [],
        "rationale": f"answer {digest.hex()[:8]}",
    }
    return openai_completion(json.dumps(content), prompt_tokens=500 + digest[4], completion_tokens=40 + digest[5] % 9)


@pytest.fixture(scope="module")
def scene_files(tmp_path_factory: pytest.TempPathFactory) -> list[str]:
    return write_scenes(tmp_path_factory.mktemp("model-scenes"), first_seed=800, persons=150, prefix="model")


@pytest.fixture
def model_server() -> Iterator[StandIn]:
    with StandIn(responder=answer) as server:
        yield server


def csv_without_timing(path: Path) -> list[dict[str, str]]:
    with path.open(encoding="utf-8", newline="") as fh:
        return [{k: v for k, v in row.items() if k not in TIMING_FIELDS} for row in csv.DictReader(fh)]


def argv(scene_files: list[str], url: str, out: Path, *more: str) -> list[str]:
    return [
        "--scene-file", *scene_files, "--systems", "rules,llm:openai-compatible:stand-in@" + url,
        "--frames", "20", "--assess-every", "10", "--out", str(out), "--quiet", "--no-stats", *more,
    ]  # fmt: skip


def test_a_replay_from_the_cache_gives_the_same_results_with_no_model_server(
    scene_files: list[str], tmp_path: Path, clean_env: None
) -> None:
    with StandIn(responder=answer) as server:
        url = server.url
        assert main(argv(scene_files, url, tmp_path / "first")) == 0
        calls = len(server.received)
    assert calls == 4  # 2 scenes × 2 assessments
    cache = [json.loads(line) for line in (tmp_path / "first" / MODEL_CACHE).read_text().splitlines()]
    assert len(cache) == 4 and {e["scene_id"] for e in cache} == {"model-1", "model-2"}
    # the server is stopped: any model call now would fail and show in the records
    assert main(argv(scene_files, url, tmp_path / "replay", "--replay", str(tmp_path / "first"))) == 0
    first = csv_without_timing(tmp_path / "first" / "results.csv")
    assert all(row["error"] == "" for row in first) and {row["llm_calls"] for row in first} == {"0", "1"}
    # exactly: the replay's records carry the recorded campaign's timings (it asked no model to time)
    recorded = (tmp_path / "first" / "results.csv").read_bytes()
    assert (tmp_path / "replay" / "results.csv").read_bytes() == recorded
    # and a replay of the replay: it kept the entries it answered from
    assert main(argv(scene_files, url, tmp_path / "again", "--replay", str(tmp_path / "replay"))) == 0
    assert (tmp_path / "again" / "results.csv").read_bytes() == recorded


def test_a_replay_missing_an_answer_gives_an_error_record_not_a_call(
    scene_files: list[str], tmp_path: Path, clean_env: None, model_server: StandIn
) -> None:
    assert main(argv(scene_files[:1], model_server.url, tmp_path / "first")) == 0
    lines = (tmp_path / "first" / MODEL_CACHE).read_text().splitlines()
    (tmp_path / "first" / MODEL_CACHE).write_text(lines[0] + "\n")  # the second assessment's answer is gone
    sent = len(model_server.received)
    assert main(argv(scene_files[:1], model_server.url, tmp_path / "replay", "--replay", str(tmp_path / "first"))) == 0
    assert len(model_server.received) == sent  # a replay asks no model, even one that is there
    (record,) = [r for r in read_records(tmp_path / "replay" / "results.jsonl") if r.system != "rules"]
    assert record.error is not None and "not in the response cache" in record.error


def test_replay_of_a_directory_without_a_cache_is_a_usage_error(
    scene_files: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str], clean_env: None
) -> None:
    (tmp_path / "empty").mkdir()
    code = main(argv(scene_files, "http://127.0.0.1:9", tmp_path / "out", "--replay", str(tmp_path / "empty")))
    err = capsys.readouterr().err
    assert code == 2 and "model_cache.jsonl not found" in err and "Traceback" not in err


def test_a_server_that_always_answers_429_halves_the_limit_and_ends_in_error_records(
    scene_files: list[str], tmp_path: Path, clean_env: None
) -> None:
    def busy(path: str, body: Any) -> Reply:
        return openai_error(429, "Rate limit reached", type="requests", headers={"Retry-After": "0"})

    settings = ModelSettings(max_concurrent=4, backoff_initial_s=0.05, backoff_max_s=0.2, give_up_after=2)
    with StandIn(responder=busy) as server:
        system = parse_systems(f"llm:openai-compatible:busy@{server.url}", environ={})
        from flight.sim.scene_file import load_scene

        plan = CampaignPlan(
            scenes=[load_scene(Path(f)) for f in scene_files], systems=system,
            settings=EpisodeSettings(frames=40, assess_every=5),
        )  # fmt: skip
        result = run_campaign(plan, tmp_path, quiet=True, models=settings)
        requests = len(server.received)
        limiter = limiter_for(f"{server.url}/v1", settings)
    assert [r.assessment for r in result.records] == [None, None]
    assert all(r.error is not None and r.error.startswith("rate_limited") for r in result.records)
    assert limiter.limit == 1 and limiter.strikes >= settings.give_up_after
    # 16 assessments; once given up on, the endpoint is asked only when its pause ends: far fewer than 16 × 3
    assert requests < 16 * 3
    assert not (tmp_path / MODEL_CACHE).exists()  # a rate limit is not an answer: nothing cached


def test_the_limit_halves_on_429_and_recovers_with_answers() -> None:
    now = [0.0]
    limiter = EndpointLimiter(8, backoff_initial_s=1.0, backoff_max_s=4.0, give_up_after=3, clock=lambda: now[0])
    assert limiter.acquire()
    limiter.release(rate_limited=True, retry_after_s=None)
    assert (limiter.limit, limiter.resume_at) == (4, 1.0)
    limiter.release(rate_limited=True, retry_after_s=None, acquired=False)
    limiter.release(rate_limited=True, retry_after_s=None, acquired=False)
    assert limiter.limit == 1 and limiter.strikes == 3
    assert not limiter.acquire()  # given up on until the pause ends
    now[0] = limiter.resume_at
    assert limiter.acquire()  # one probe after the pause
    limiter.release(rate_limited=False, retry_after_s=None)
    assert limiter.limit == 2 and limiter.strikes == 0
    for _ in range(2 + 3 + 4 + 5 + 6 + 7 + 8):
        assert limiter.acquire()
        limiter.release(rate_limited=False, retry_after_s=None)
    assert limiter.limit == 8  # back to the cap, never above


def test_a_budget_of_one_call_stops_cleanly_and_a_larger_one_goes_on(
    scene_files: list[str], tmp_path: Path, clean_env: None, model_server: StandIn, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "budget"
    assert main(argv(scene_files, model_server.url, out, "--budget-calls", "1")) == 3
    err = capsys.readouterr().err
    assert "budget spent (model calls: 2 of 1)" in err and "2 of 4 kept" in err and "Traceback" not in err
    kept = read_records(out / "results.jsonl")
    assert len(kept) == 2 and len({r.scene_id for r in kept}) == 1  # one scene's job, whole
    assert not (out / "results.csv").exists()  # the campaign is not complete
    assert main(argv(scene_files, model_server.url, out, "--budget-calls", "10")) == 0
    assert len(read_records(out / "results.jsonl")) == 4 and len(model_server.received) == 4


def test_a_cost_budget_counts_the_prices_and_needs_one_for_every_model(
    scene_files: list[str], tmp_path: Path, clean_env: None, model_server: StandIn, capsys: pytest.CaptureFixture[str]
) -> None:
    args = argv(scene_files, model_server.url, tmp_path / "usd", "--budget-usd", "0.001")
    assert main(args) == 2
    assert "--budget-usd needs a --price for every model; none for: stand-in" in capsys.readouterr().err
    assert main([*args, "--price", "stand-in=1/2"]) == 3  # about $0.0011 per scene: over after the first job
    assert "cost: $0.00" in capsys.readouterr().err
    assert main([*args, "--price", "stand-in=one/2"]) == 2
    assert "expected MODEL=IN/OUT" in capsys.readouterr().err


def test_tokens_count_toward_the_budget_and_a_campaign_without_model_calls_spends_nothing(tmp_path: Path) -> None:
    from evaluation.campaign.budget import Spend
    from evaluation.campaign.model_calls import ModelUsage

    spend = Spend()
    budget = Budget(tokens=1000)
    spend.add([ModelUsage(model="m", calls=1, prompt_tokens=600, completion_tokens=0)], budget)
    assert spend.exceeded(budget) is None
    spend.add([ModelUsage(model="m", calls=1, prompt_tokens=400, completion_tokens=0)], budget)
    assert spend.exceeded(budget) == "tokens: 1000 of 1000"
    plan = CampaignPlan(scenes=[generate_scene(1, persons=10)], systems=parse_systems("rules", environ={}),
                        settings=EpisodeSettings(frames=2))  # fmt: skip
    result = run_campaign(plan, tmp_path, quiet=True, budget=Budget(calls=1))  # no model calls: never spent
    assert len(result.records) == 1


def test_a_damaged_cache_is_a_usage_error_naming_its_line(
    scene_files: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str], clean_env: None
) -> None:
    source = tmp_path / "damaged"
    source.mkdir()
    (source / MODEL_CACHE).write_text('{"scene_id": "model-1"}\n{"also": "broken"}\n', encoding="utf-8")
    code = main(argv(scene_files, "http://127.0.0.1:9", tmp_path / "out", "--replay", str(source)))
    err = capsys.readouterr().err
    assert code == 2 and f"{source / MODEL_CACHE}, line 1: not a cached model response" in err
    assert "Traceback" not in err and not (tmp_path / "out" / "results.jsonl").exists()
    (source / MODEL_CACHE).unlink()
    os.mkfifo(source / MODEL_CACHE)  # a FIFO would block a reader: refused before it is opened
    assert main(argv(scene_files, "http://127.0.0.1:9", tmp_path / "fifo", "--replay", str(source))) == 2
    assert "not a regular file" in capsys.readouterr().err
