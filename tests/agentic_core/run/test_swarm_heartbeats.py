"""A swarm run that loses the ground, then a UAV: its peers stop hearing its signed heartbeats, and only after the
mission's timeout of silence on the swarm's clock is it failed — by the messages, not by the ground's view of its
vehicle — and its sector agreed anew among the others by consensus."""

from __future__ import annotations

import json
import threading
from pathlib import Path
from typing import Any

import pytest

from agentic_core.run.swarm_run import SwarmRun, SwarmSettings
from tests.waiting import wait_for

REPO = Path(__file__).resolve().parents[3]
MISSION = REPO / "missions" / "hajj_swarm.yaml"


@pytest.mark.slow
@pytest.mark.timeout(600)
def test_a_uav_lost_after_the_ground_is_failed_by_its_silence(tmp_path: Path, smtp: Any) -> None:
    settings = SwarmSettings(mission=MISSION, vehicles=3, runs_dir=tmp_path, speed=None, camera_hz=5.0,
                             ground_link_lost_s=5.0)  # fmt: skip
    swarm = SwarmRun(settings)
    outcome: dict[str, Any] = {}
    flight = threading.Thread(target=lambda: outcome.update(swarm.execute()), name="test-swarm")
    flight.start()
    try:
        wait_for(lambda: swarm.coordinator.ground_lost, timeout_s=120.0, what="the ground lost")
        victim = swarm.coordinator.manager.allocation.awarded["survey:S1"]
        seat = next(s for s in swarm.seats if s.uav == victim)
        wait_for(lambda: seat.run is not None and (s := seat.run.last_sample) is not None and s.alt_m > 10.0,
                 timeout_s=120.0, what=f"{victim} in the air")  # fmt: skip
        assert swarm.coordinator.coverage["S1"] == []
        swarm.kill(victim)
        killed_at = swarm.time_s()
        wait_for(lambda: victim in swarm.coordinator.failed, timeout_s=120.0, what="the peers noticing the silence")
    finally:
        flight.join(timeout=500.0)
    assert not flight.is_alive()
    records = [json.loads(line) for line in (swarm.dir / "swarm.jsonl").read_text(encoding="utf-8").splitlines()]
    (failed,) = [r for r in records if r["event"] == "failed"]
    assert failed["uav"] == victim and failed["why"].startswith("no heartbeat heard for")
    assert failed["sim_t"] - killed_at >= swarm.coordinator.heartbeats.timeout_s - 1.0  # silence, not memory
    assert "survey:S1" in failed["moved"]
    agreed = [r for r in records if r["event"] == "consensus" and "survey:S1" in r["tasks"]]
    assert agreed and victim not in agreed[-1]["among"] and agreed[-1]["awarded"]["survey:S1"] != victim
    assert not [r for r in records if r["event"] == "round" and r["sim_t"] > 5.0 + 1.0]  # no ground round after
    assert outcome["sectors"]["S1"] and victim not in outcome["sectors"]["S1"] and outcome["lost"] == [victim]
