"""``world_map.jsonl``: a World Model is recorded when what the map shows changes (an object appears, goes, moves a
metre, changes state; a relation), never twice for the same picture, at most once a period of the vehicle's clock,
and never more than the bound; a resumed run counts what was written before."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from agentic_core.contracts.world_model import WorldModel
from agentic_core.run import world_map
from agentic_core.run.state_files import read_jsonl
from agentic_core.run.world_map import WorldMapLog

LAT, LON = 21.4133, 39.8933
POSE = {"north": 0, "east": 0, "down": 0, "lat": LAT, "lon": LON, "alt": 0}


def world(t: float, *people: tuple[str, float], relations: list[dict[str, Any]] | None = None) -> WorldModel:
    """People ``(id, metres north of a fixed point)`` at time ``t``."""
    objects = [{"id": pid, "class": "person", "pose": {**POSE, "north": north, "lat": LAT + north / 111_320.0},
                "conf": 0.8, "cov": [[4.0, 0.5], [0.5, 2.0]]} for pid, north in people]  # fmt: skip
    return WorldModel.model_validate({"timestamp": t, "frame": int(t * 10), "ego_pose": POSE, "objects": objects,
                                      "relations": relations or []})  # fmt: skip


def test_only_changes_are_recorded_at_most_once_a_period(tmp_path: Path) -> None:
    log = WorldMapLog(tmp_path / "world_map.jsonl", period_s=1.0)
    log(world(0.0, ("P-1", 0.0)))
    log(world(0.5, ("P-1", 5.0)))  # moved, but within the period
    log(world(1.5, ("P-1", 0.3)))  # a period on, but not moved a metre since the last record: the same picture
    log(world(2.6, ("P-1", 3.0)))  # moved
    log(world(3.7, ("P-1", 3.0), ("P-2", 9.0)))  # someone new
    near = [{"subj": "P-1", "pred": "near", "obj": "P-2"}, {"subj": "P-1", "pred": "stationary"}]
    log(world(4.8, ("P-1", 3.0), ("P-2", 9.0), relations=near))  # a relation the map draws
    log(world(5.9, ("P-1", 3.0), ("P-2", 9.0), relations=near[:1]))  # only an undrawn relation went: no change
    log(world(7.0))  # everyone gone
    records = read_jsonl(log.path)
    assert [r["t"] for r in records] == [0.0, 2.6, 3.7, 4.8, 7.0]
    assert records[3]["relations"] == [{"subj": "P-1", "pred": "near", "obj": "P-2"}]
    assert records[0]["objects"][0]["cov"] == [[4.0, 0.5], [0.5, 2.0]] and records[-1]["objects"] == []


def test_the_record_is_bounded_in_records_and_bytes_and_a_resumed_run_counts_what_it_wrote(tmp_path: Path) -> None:
    path = tmp_path / "world_map.jsonl"
    log = WorldMapLog(path, period_s=0.0, most=10)
    for k in range(50):
        log(world(float(k), ("P-1", float(k * 2))))
    assert len(read_jsonl(path)) == 10
    again = WorldMapLog(path, period_s=0.0, most=12)  # resumed: two more at most
    for k in range(50, 60):
        again(world(float(k), ("P-1", float(k * 2))))
    assert len(read_jsonl(path)) == 12
    size = path.stat().st_size
    by_bytes = WorldMapLog(path, period_s=0.0, most=1000, most_bytes=size + 1)  # one more record, then full
    for k in range(60, 70):
        by_bytes(world(float(k), ("P-1", float(k * 2))))
    assert len(read_jsonl(path)) == 13 and by_bytes.bytes == path.stat().st_size


def test_a_still_scene_is_looked_at_once_a_period_not_every_frame(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    looks: list[float] = []
    real = world_map._shape

    def counted(w: WorldModel) -> tuple[Any, ...]:
        looks.append(w.timestamp)
        return real(w)

    monkeypatch.setattr(world_map, "_shape", counted)
    log = world_map.WorldMapLog(tmp_path / "world_map.jsonl", period_s=1.0)
    for frame in range(90):  # three seconds at 30 frames a second, nobody moving
        log(world(frame / 30.0, ("P-1", 0.0)))
    assert len(looks) == 3 and len(read_jsonl(log.path)) == 1
