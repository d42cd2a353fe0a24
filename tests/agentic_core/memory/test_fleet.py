"""The fleet's memory: what a run's events become, where they are placed, what a reasoner is told, how a memory
is explained (``why``), invalidated, and how knowledge documents are ingested and superseded."""

from __future__ import annotations

import datetime as dt
from pathlib import Path
from typing import Any

import pytest

from agentic_core.contracts.errors import InputError
from agentic_core.contracts.events import RunEvent
from agentic_core.contracts.memory import Provenance, RecallPort, Recollection
from agentic_core.memory.cli import main as memory_main
from agentic_core.memory.fleet import FleetMemory
from agentic_core.memory.knowledge import chunk, ingest, search_knowledge
from agentic_core.memory.recorder import RunRecorder, step_of
from agentic_core.perception.world_model import WorldModel
from agentic_core.reasoning.remembering import Remembering
from agentic_core.reasoning.rules import RuleReasoner

GATE = (21.4130, 39.8890)
CASUALTY = (21.41336, 39.8933)


def event(kind: str, seq: int, **fields: Any) -> RunEvent:
    return RunEvent(kind=kind, seq=seq, sim_t=seq * 10.0, **fields)


def recorder(fleet: FleetMemory, run_id: str = "R1") -> RunRecorder:
    return RunRecorder(fleet, run_id, aircraft=lambda: GATE, locate=lambda oid: CASUALTY if oid == "P-9" else None,
                       mission="hajj-patrol", scene="small-normal")  # fmt: skip


def test_a_runs_events_become_placed_memories_with_provenance() -> None:
    fleet = FleetMemory(":memory:", embed=False)
    rec = recorder(fleet)
    rec.on_event(
        event(
            "tool",
            8,
            name="incidents.log",
            status="ok",
            key="R1:patrol/log_west#1:1.1",
            args={"kind": "crowd_density", "severity": "low", "description": "west gate: 104 persons"},
        )
    )
    rec.on_event(event("tool", 9, name="incidents.log", status="error", args={"kind": "x"}))  # failed: not a fact
    rec.on_event(event("decision", 20, assessment={"severity": "critical", "subject_id": "P-9", "rationale": "down"}))
    rec.on_event(event("decision", 21, assessment={"severity": "none", "rationale": "people are moving normally"}))
    rec.on_event(event("approval", 22, request={"question": "land near P-9?"}, answer=False, said="too crowded"))
    rec.on_event(event("tool", 23, name="alerts.notify", status="ok", args={"subject": "casualty P-9"}))
    written = rec.flush()
    assert written == ["incident/R1:8", "decision/R1:20", "casualty/R1:20", "approval/R1:22", "alert/R1:23"]
    assert rec.flush() == []  # written once
    incident = fleet.recall(*GATE, within_m=10, kinds=("incident",))[0]
    assert incident.text == "crowd_density: west gate: 104 persons" and incident.severity == "low"
    assert incident.provenance == Provenance(run_id="R1", seq=8, step="patrol/log_west#1", sim_t=80.0,
                                             mission="hajj-patrol", scene="small-normal")  # fmt: skip
    casualty = fleet.recall(*CASUALTY, within_m=5, kinds=("casualty",))[0]
    assert (casualty.lat, casualty.lon) == CASUALTY  # where the subject was, not where the aircraft was
    approval = fleet.recall(*GATE, within_m=5, kinds=("approval",))[0]
    assert approval.provenance.verdict == "declined" and "too crowded" in approval.text


def test_recall_is_near_nearest_first_believed_only_and_not_the_runs_own() -> None:
    fleet = FleetMemory(":memory:", embed=False)
    fleet.remember("incident", "R1:1", "at the gate", lat=GATE[0], lon=GATE[1], provenance=Provenance(run_id="R1"))
    fleet.remember("incident", "R1:2", "100 m north", lat=GATE[0] + 0.0009, lon=GATE[1],
                   provenance=Provenance(run_id="R1"))  # fmt: skip
    fleet.remember(
        "incident", "R1:3", "2 km away", lat=GATE[0] + 0.018, lon=GATE[1], provenance=Provenance(run_id="R1")
    )
    fleet.remember("incident", "R2:1", "this run", lat=GATE[0], lon=GATE[1], provenance=Provenance(run_id="R2"))
    fleet.remember("incident", "R1:4", "nowhere in particular", provenance=Provenance(run_id="R1"))
    assert [r.key for r in fleet.recall(*GATE, within_m=200, exclude_run="R2")] == ["R1:1", "R1:2"]
    fleet.invalidate("incident/R1:1", "double-counted", by="amal")
    assert [r.key for r in fleet.recall(*GATE, within_m=200, exclude_run="R2")] == ["R1:2"]
    assert any("invalidate (double-counted, by amal)" in line for line in fleet.why("incident/R1:1"))


def world(stationary_s: float) -> WorldModel:
    return WorldModel.model_validate({"timestamp": 5.0, "ego_pose": {"north": 0, "east": 0, "down": -30,
        "lat": 21.4133, "lon": 39.8933, "alt": 30}, "objects": [{"id": "P-2", "class": "person", "conf": 0.8,
        "stationary_s": stationary_s, "pose": {"north": 4, "east": 0, "down": 0, "lat": 21.41334, "lon": 39.8933,
        "alt": 0}}]})  # fmt: skip


def recollection(kind: Any, lat: float) -> Recollection:
    return Recollection(key="R1:20", kind=kind, text="seen before", lat=lat, lon=39.8933, distance_m=3.0,
                        provenance=Provenance(run_id="R1", seq=20, step="look", sim_t=12.0))  # fmt: skip


def fixed(memories: list[Recollection]) -> RecallPort:
    def recall(world: WorldModel, focus: str | None) -> list[Recollection]:
        return memories

    return recall


def severity(reasoner: Remembering, w: WorldModel) -> str | None:
    a = reasoner.assess(w).assessment
    assert a is not None
    return a.severity


def test_a_remembered_casualty_is_a_prior_only_for_someone_still_and_close() -> None:
    rules = RuleReasoner()
    here = recollection("casualty", CASUALTY[0])
    assert severity(Remembering(rules, fixed([here])), world(3.0)) == "high"
    walking = Remembering(rules, fixed([here])).assess(world(0.0)).assessment
    assert walking is not None and walking.severity == "none" and "[memory casualty/R1:20]" in walking.rationale
    far = recollection("casualty", CASUALTY[0] + 0.001)  # 110 m north
    assert severity(Remembering(rules, fixed([far])), world(3.0)) == "none"
    incident = recollection("incident", CASUALTY[0])  # not a casualty: cited, no prior
    assert severity(Remembering(rules, fixed([incident])), world(3.0)) == "none"


def test_without_memories_or_when_recall_fails_the_reasoner_answers_as_before() -> None:
    rules = RuleReasoner()
    plain = rules.assess(world(3.0)).assessment

    def broken(w: WorldModel, f: str | None) -> list[Recollection]:
        raise OSError("disk gone")

    for recall in (fixed([]), broken):
        wrapped = Remembering(rules, recall)
        assert wrapped.name == "rules"
        assert wrapped.assess(world(3.0)).assessment == plain


def test_why_follows_citations_and_survives_a_cycle() -> None:
    fleet = FleetMemory(":memory:", embed=False)
    fleet.remember("incident", "R1:8", "west gate busy", lat=GATE[0], lon=GATE[1], cites=["decision/R2:5"],
                   provenance=Provenance(run_id="R1", seq=8, step="patrol/log_west#1"))  # fmt: skip
    fleet.remember("decision", "R2:5", "cited it", cites=["incident/R1:8"], provenance=Provenance(run_id="R2", seq=5))
    lines = fleet.why("decision/R2:5")
    assert lines[0] == "decision/R2:5: cited it"
    assert any("incident/R1:8: west gate busy at 21.41300, 39.88900" in line for line in lines)
    assert any("run_id R1, seq 8, step patrol/log_west#1" in line for line in lines)
    assert lines[-1].strip() == "decision/R2:5: (above)"
    with pytest.raises(InputError, match="KIND/KEY"):
        fleet.why("R2:5")


DOC = """---
source: test notes
version: "{version}"
valid_until: {until}
---
# Heat

Cool first, then move the patient.

## Shade

Tents and shade structures are where people recover.
"""


def test_knowledge_is_chunked_with_its_source_and_older_versions_are_superseded_not_erased(tmp_path: Path) -> None:
    fleet = FleetMemory(":memory:", embed=False)
    doc = tmp_path / "heat.md"
    doc.write_text(DOC.format(version="1", until="2099-01-01"))
    assert ingest(fleet.store, [doc]) == ["heat@1#0", "heat@1#1"]
    doc.write_text(DOC.format(version="2", until="2099-01-01"))
    assert ingest(fleet.store, [doc]) == ["heat@2#0", "heat@2#1"]
    hits = search_knowledge(fleet.store, "shade tents")
    assert hits[0].key == "heat@2#1" and {h.value["version"] for h in hits} == {"2"}
    old = fleet.store.get(("knowledge", "heat"), "heat@1#1")
    assert old is not None and old.invalidated is not None and old.invalidated.reason == "superseded by version 2"
    assert hits[0].value["source"] == "test notes" and hits[0].value["heading"] == "Heat / Shade"


def test_expired_knowledge_is_not_retrieved(tmp_path: Path) -> None:
    fleet = FleetMemory(":memory:", embed=False)
    doc = tmp_path / "old.md"
    doc.write_text(DOC.format(version="1", until="2020-01-01"))
    ingest(fleet.store, [doc])
    assert search_knowledge(fleet.store, "shade") == []
    then = dt.datetime(2019, 6, 1, tzinfo=dt.UTC).timestamp()
    assert search_knowledge(fleet.store, "shade", now=then) != []


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("# no front matter\n", r"x\.md:1: .*front matter"),
        ("---\nsource: s\nversion: 1\n", r"x\.md:1: the front matter has no closing"),
        ("---\nsource: s\nversion: 1\n---\ntext\n", r"x\.md:2: the front matter needs 'valid_until'"),
        ("---\nsource: s\nversion: 1\nvalid_until: soon\n---\ntext\n", r"valid_until 'soon' is not a date"),
        ("---\n[unclosed\n---\ntext\n", r"x\.md: the front matter is not YAML"),
        ("---\nsource: s\nversion: 1\nvalid_until: 2099-01-01\n---\n\n", r"no text after its front matter"),
    ],
)
def test_bad_documents_are_refused_naming_the_file_and_nothing_is_written(
    tmp_path: Path, text: str, message: str
) -> None:
    fleet = FleetMemory(":memory:", embed=False)
    good, bad = tmp_path / "good.md", tmp_path / "x.md"
    good.write_text(DOC.format(version="1", until="2099-01-01"))
    bad.write_text(text)
    with pytest.raises(InputError, match=message):
        ingest(fleet.store, [good, bad])
    assert fleet.store.list_namespaces() == []


def test_a_long_section_is_cut_at_paragraphs() -> None:
    pieces = chunk("# T\n\n" + "\n\n".join("word " * 30 for _ in range(6)), max_chars=200)
    assert len(pieces) >= 3 and all(len(text) <= 200 + len("T\n\n") for _, text in pieces)
    assert all(text.startswith("T\n\n") for _, text in pieces)


def test_step_of_reads_the_idempotency_key() -> None:
    assert step_of("20261127-r:patrol/log_west#1:1.1") == "patrol/log_west#1"
    assert step_of(None) is None and step_of("plain") is None


def test_the_cli_ingests_searches_explains_and_refuses_clearly(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    store = tmp_path / "m.db"
    assert memory_main(["--memory", str(store), "why", "incident/R1:1"]) == 2  # no memory yet
    assert "no memory there yet" in capsys.readouterr().err
    doc = tmp_path / "heat.md"
    doc.write_text(DOC.format(version="1", until="2099-01-01"))
    assert memory_main(["--memory", str(store), "ingest", str(doc)]) == 0
    out = capsys.readouterr()
    assert "ingested 2 chunks" in out.out and "search: " in out.err
    assert memory_main(["--memory", str(store), "search", "--knowledge", "cool the patient"]) == 0
    assert "heat.md v1" in capsys.readouterr().out
    assert memory_main(["--memory", str(store), "search", "--near", "21.4,nope"]) == 2
    assert "--near takes LAT,LON,METRES" in capsys.readouterr().err
    assert memory_main(["--memory", str(store), "why", "incident/R9:9"]) == 1
    assert "not in this memory" in capsys.readouterr().out
    assert memory_main(["--memory", str(store), "ingest", str(tmp_path / "missing.md")]) == 2
