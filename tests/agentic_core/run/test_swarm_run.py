"""``agentic-uav swarm run``: the shipped swarm mission flown by four simulated UAVs on one clock, each with its own
agent loop — sectors covered, the casualty found, verified by a second UAV, alerted, and served by the medic UAV
awarded the kit, with the separation kept and every leg reserved in the airspace; and, in a second run, a UAV killed
mid-mission whose sector another UAV covers, while forged and replayed awards posted to a UAV's A2A endpoint are
refused and audited, then the ground link lost, after which the UAVs left agree the verification and the delivery
among themselves."""

from __future__ import annotations

import asyncio
import json
import threading
from pathlib import Path
from typing import Any

import pytest

from agentic_core.cli import main
from agentic_core.contracts.swarm import SwarmMessage, UavState
from agentic_core.run.swarm_run import SwarmRun, SwarmSettings
from agentic_core.swarm.a2a_client import A2APeer, PeerError
from agentic_core.swarm.signing import Sealer, SwarmKey
from tests.agentic_core.swarm.wire import tap_wire
from tests.waiting import wait_for

REPO = Path(__file__).resolve().parents[3]
MISSION = REPO / "missions" / "hajj_swarm.yaml"

CAMERA_HZ = 5.0
"""Each UAV's camera: enough to find and verify the casualty, and four perception loops fit a shared machine."""

pytestmark = [pytest.mark.slow, pytest.mark.timeout(600)]


async def _post(url: str, message: SwarmMessage) -> SwarmMessage | None:
    async with A2APeer(url) as peer:
        return await peer.send(message)


async def _card_state(url: str, key: SwarmKey) -> UavState:
    async with A2APeer(url, card_key=key) as peer:
        return await peer.state()


def _lines(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines()]


@pytest.mark.slow
def test_four_uavs_cover_the_sectors_and_answer_the_casualty_together(tmp_path: Path, smtp: Any) -> None:
    argv = ["swarm", "run", str(MISSION), "--vehicles", "4", "--runs-dir", str(tmp_path), "--speed", "max"]
    code = main([*argv, "--camera-hz", str(CAMERA_HZ)])
    (swarm_dir,) = tmp_path.iterdir()
    summary = json.loads((swarm_dir / "summary.json").read_text(encoding="utf-8"))
    assert code == 0, summary["problems"]
    assert summary["outcome"] == "completed" and summary["lost"] == []
    assert sorted(summary["sectors"]) == ["S1", "S2", "S3", "S4"] and all(summary["sectors"].values())
    assert [u["system_id"] for u in summary["uavs"].values()] == [1, 2, 3, 4]
    assert {u["outcome"] for u in summary["uavs"].values()} == {"completed"}
    (casualty,) = [c for c in summary["casualties"] if c["truth"] == "P-12"]
    assert (
        casualty["verified"] and len(casualty["verified_by"]) >= 2 and casualty["found_by"] in casualty["verified_by"]
    )
    assert casualty["alerted"] and casualty["delivered"]
    medic = casualty["delivery_awarded"]
    assert summary["uavs"][medic]["role"] == "medic"  # only a UAV with a kit may be awarded the delivery
    separation = summary["separation"]
    assert separation["losses"] == 0 and separation["instants"] > 100
    assert separation["min_distance_m"] >= min(separation["horizontal_m"], separation["vertical_m"])
    records = _lines(swarm_dir / "swarm.jsonl")
    (served,) = [r["agents"] for r in records if r["event"] == "a2a"]
    assert sorted(served) == sorted(summary["uavs"]) and {u: a["url"] for u, a in summary["a2a"].items()} == served
    assert all(a["requests"] >= len(summary["sectors"]) for a in summary["a2a"].values())  # the rounds over HTTP
    kit_round = next(r for r in records if r["event"] == "round" and r["task"].startswith("deliver_kit:"))
    assert set(kit_round["bids"]) <= {u for u, v in summary["uavs"].items() if v["role"] == "medic"}
    assert kit_round["awarded"] == min(kit_round["bids"], key=kit_round["bids"].get) == medic
    assert any(r["event"] == "delivered" and r["uav"] == medic for r in records)
    legs = [r for r in records if r["event"] == "leg"]  # every leg reserved before it was flown, written down
    assert {r["uav"] for r in legs if r["tool"] == "flight.takeoff"} == set(summary["uavs"])
    assert {r["uav"] for r in legs if r["tool"] == "flight.rtl"} == set(summary["uavs"])
    assert [r["uav"] for r in legs if r["tool"] == "flight.land"] == [medic]  # the descent for the delivery
    assert not [r for r in legs if r["decision"] in ("refused", "strayed")]
    decided = summary["airspace"]
    assert sum(decided[d] for d in ("granted", "relayered", "delayed")) == len(legs) and decided["released"] == 4
    released = sorted(r["uav"] for r in records if r["event"] == "airspace_released")
    assert released == sorted(summary["uavs"])  # each landed at home and gave its airspace back
    assert len(smtp.inbox.envelopes) == 1  # one alert for the fleet, not one per UAV that saw the casualty
    for uav in summary["uavs"].values():  # each UAV's own run: its trace and report
        run_dir = Path(uav["run_dir"])
        assert (run_dir / "trace.jsonl").is_file() and (run_dir / "report.md").is_file()
    assert (swarm_dir / "missions" / "uav-3.yaml").read_text(encoding="utf-8").count("deliver_kit") >= 1
    assert "deliver_kit" not in (swarm_dir / "missions" / "uav-1.yaml").read_text(encoding="utf-8")  # a scout's


LOST_AT = 40.0
"""When the ground link is lost in the second run: the sectors are being flown; the casualty is not yet found."""


@pytest.mark.slow
def test_a_uav_killed_then_the_ground_link_lost_the_rest_finish_among_themselves(
    tmp_path: Path, smtp: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """One run for two faults, one after the other (a run costs a minute of this machine): a UAV killed in its climb
    loses its sector to another by Contract Net from the ground, while forged and replayed awards posted to a UAV's A2A
    endpoint are refused and audited; then the ground link is lost, and the three left agree the verification and the
    delivery among themselves — never with the dead UAV — and finish."""
    built: list[tuple[SwarmRun, list[tuple[str, SwarmMessage]]]] = []

    def fly(settings: SwarmSettings, progress: Any = None) -> dict[str, Any]:  # the CLI's, with the test's hands on it
        swarm = SwarmRun(settings, progress=progress)
        built.append((swarm, tap_wire(swarm.coordinator)))
        return swarm.execute()

    monkeypatch.setattr("agentic_core.run.swarm_run.run_swarm", fly)
    argv = ["swarm", "run", str(MISSION), "--vehicles", "4", "--runs-dir", str(tmp_path), "--speed", "max"]
    code: list[int] = []
    cli = [*argv, "--camera-hz", str(CAMERA_HZ), "--fault", f"ground_link@t={LOST_AT:g}s"]
    flight = threading.Thread(target=lambda: code.append(main(cli)), name="test-swarm")
    flight.start()
    try:
        swarm, wire = wait_for(lambda: built, timeout_s=60.0, what="the swarm built")[0]
        sectors: dict[str, str] = wait_for(lambda: dict(swarm.coordinator.manager.allocation.awarded), timeout_s=60.0)
        victim = sectors["survey:S1"]  # the strip nearest the pads: P-12 lies in S3
        seat = next(s for s in swarm.seats if s.uav == victim)
        wait_for(lambda: seat.run is not None and (s := seat.run.last_sample) is not None and s.alt_m > 10.0,
                 timeout_s=120.0, what=f"{victim} in the air")  # fmt: skip
        assert swarm.coordinator.coverage["S1"] == []
        swarm.kill(victim)
        wait_for(lambda: victim in swarm.coordinator.failed, timeout_s=60.0, what="the swarm noticing")
        assert not swarm.coordinator.ground_lost  # the first fault is the ground's to handle
        uav, award = next((u, m) for u, m in wire if m.kind == "award" and u != victim)
        agents = swarm.coordinator.agents()
        forged = Sealer(SwarmKey.generate("mina"), "ground").seal("award", award.body, recipient=uav)
        for bad in (award, forged):  # the genuine award again (replayed), and one signed with another key
            with pytest.raises(PeerError):
                asyncio.run(_post(agents[uav], bad))
        victim_card = asyncio.run(_card_state(agents[victim], swarm.coordinator.key))  # served mid-run, signed
        assert victim_card.uav_id == victim and victim_card.status == "failed"
    finally:
        flight.join(timeout=500.0)
    assert not flight.is_alive()
    summary = json.loads((swarm.dir / "summary.json").read_text(encoding="utf-8"))
    assert code == [3] and summary["outcome"] == "degraded" and summary["exit"] == 3
    assert summary["problems"] == [] and summary["lost"] == [victim]  # degraded by the lost UAV alone
    assert summary["uavs"][victim]["outcome"] != "completed"
    heir = summary["allocation"]["survey:S1"]
    assert heir != victim and summary["sectors"]["S1"] and victim not in summary["sectors"]["S1"]
    records = _lines(swarm.dir / "swarm.jsonl")
    failed = next(i for i, r in enumerate(records) if r["event"] == "failed")
    assert records[failed]["uav"] == victim and "survey:S1" in records[failed]["moved"]
    moved = next(r for r in records[failed:] if r["event"] == "round" and r["task"] == "survey:S1")
    assert moved["awarded"] == heir and victim not in moved["bids"]  # re-auctioned by the ground
    refusals = _lines(swarm.dir / "refusals.jsonl")
    assert [(r["receiver"], r["reason"], r["kind"]) for r in refusals] == [
        (uav, "replayed", "award"),
        (uav, "forged", "award"),
    ]
    assert summary["refusals"] == {"replayed": 1, "forged": 1}
    assert {u: a["url"] for u, a in summary["a2a"].items()} == agents and all(
        a["requests"] > 0 for a in summary["a2a"].values()
    )  # every round of the run went over HTTP
    # the ground link lost: what was left was agreed among the live UAVs
    assert summary["ground_link_lost_s"] >= LOST_AT and all(summary["sectors"].values())
    (casualty,) = [c for c in summary["casualties"] if c["truth"] == "P-12"]
    assert casualty["verified"] and casualty["alerted"] and casualty["delivered"]
    (lost,) = [i for i, r in enumerate(records) if r["event"] == "ground_link_lost"]
    assert lost > failed and records[lost]["sim_t"] >= LOST_AT
    assert sorted(records[lost]["kept"]) == [f"survey:S{n}" for n in range(1, 5)]
    assert victim not in records[lost]["kept"].values()
    after = records[lost + 1 :]
    assert not [r for r in after if r["event"] == "round"]  # no Contract Net round from the ground after the loss
    agreed = {task: r["awarded"][task] for r in after if r["event"] == "consensus" for task in r["tasks"]}
    verify = next(t for t in agreed if t.startswith("verify_casualty:"))
    kit = next(t for t in agreed if t.startswith("deliver_kit:"))
    assert agreed[verify] != casualty["found_by"] and agreed[verify] in casualty["verified_by"]
    assert agreed[kit] == casualty["delivery_awarded"] and summary["uavs"][agreed[kit]]["role"] == "medic"
    assert all(r["agreed"] and victim not in r["among"] for r in after if r["event"] == "consensus")
    assert any(r["event"] == "delivered" and r["uav"] == agreed[kit] for r in after)
