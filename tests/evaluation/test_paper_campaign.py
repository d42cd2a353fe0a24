"""``agentic-uav eval paper-campaign``: the paper's systems through generated scenes, and a comparison table whose
paper columns come from the paper's figures and whose other columns are this campaign's metrics."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from agentic_core.cli import main as agentic_main
from evaluation.campaign.metrics import CampaignMetrics
from evaluation.campaign.paper_campaign import COMPARISON
from evaluation.paper.figures import load_figures
from tests.agentic_core.reasoning.llm.standin import StandIn
from tests.evaluation.test_campaign_models import answer


def test_the_paper_campaign_writes_its_results_beside_the_papers(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    for name in ("AGENTIC_UAV_LLM", "HTTP_PROXY", "HTTPS_PROXY"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("NO_PROXY", "127.0.0.1")
    out = tmp_path / "paper"
    with StandIn(responder=answer) as server:
        argv = ["eval", "paper-campaign", "--llm", f"openai-compatible:stand-in@{server.url}", "--scenes", "2"]
        code = agentic_main([*argv, "--out", str(out), "--", "--frames", "10", "--assess-every", "0", "--quiet"])
    assert code == 0, capsys.readouterr().err
    manifest = json.loads((out / "manifest.json").read_text())
    assert [s["name"] for s in manifest["systems"]] == ["yolo", "rules", "llm:stand-in", "hybrid"]
    assert manifest["seed"] == 0 and manifest["scene_source"]["count"] == 2
    table = (out / COMPARISON).read_text().splitlines()
    figures = load_figures()
    header = next(line for line in table if line.startswith("| Metric"))
    shorts = [figures.groups[g].short for g in ("yolo", "gemma", "gpt4")]
    assert (
        header
        == "| Metric | "
        + " | ".join(
            [*(f"paper: {s}" for s in shorts), "here: yolo", "here: rules", "here: llm:stand-in", "here: hybrid"]
        )
        + " |"
    )
    metrics = CampaignMetrics.model_validate_json((out / "metrics.json").read_text())
    arr = next(line for line in table if line.startswith("| Action Recommendation Rate"))
    cells = [c.strip() for c in arr.strip("|").split("|")][1:]
    assert cells[:3] == [f"{100 * figures.value(f'arr.{g}'):.1f}%" for g in ("yolo", "gemma", "gpt4")]
    assert cells[3:] == [f"{100 * (s.action_recommendation_rate or 0):.1f}%" for s in metrics.systems]
    assert (out / "stats.md").exists() and f"paper:    {out / COMPARISON}" in capsys.readouterr().out


def test_the_paper_campaign_needs_a_model(capsys: pytest.CaptureFixture[str]) -> None:
    assert agentic_main(["eval", "paper-campaign"]) == 2
    assert "--llm" in capsys.readouterr().err
