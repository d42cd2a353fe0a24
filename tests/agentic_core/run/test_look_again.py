"""An assessment of one object whose track is lost just now looks again (a run of missed detections) before it
judges, for a bounded time, and says in the trace whether it saw the object again."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from agentic_core.perception.world_model import WorldModel
from agentic_core.run import runner
from agentic_core.run.runner import MissionRun, RunSettings

REPO = Path(__file__).resolve().parents[3]


def world(state: str) -> WorldModel:
    person = {"id": "P-3", "class": "person", "pose": {"north": 0, "east": 0, "down": 0, "lat": 21.4133,
              "lon": 39.8933, "alt": 300}, "conf": 0.7, "state": state, "stationary_s": 12.0}  # fmt: skip
    ego = {"north": 0, "east": 0, "down": -15, "lat": 21.4133, "lon": 39.8933, "alt": 315}
    return WorldModel.model_validate({"timestamp": 60.0, "ego_pose": ego, "objects": [person]})


class Frames:
    """Stands in for the perception loop: the World Model the camera has produced so far."""

    def __init__(self, first: WorldModel) -> None:
        self.world = first


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> Iterator[MissionRun]:
    built = MissionRun(
        RunSettings(mission=REPO / "missions" / "hajj_emergency.yaml", runs_dir=tmp_path_factory.mktemp("runs"))
    )
    yield built
    built.close()


def logged(run: MissionRun) -> list[Any]:
    return [r["summary"] for r in run.trace.records if r["kind"] == "log"]


@pytest.mark.parametrize("seen_again", [True, False])
def test_a_lost_track_is_looked_at_again_before_it_is_judged(
    run: MissionRun, monkeypatch: pytest.MonkeyPatch, seen_again: bool
) -> None:
    monkeypatch.setattr(runner, "LOOK_AGAIN_S", 0.3)
    frames = Frames(world("lost"))
    run.loop = frames  # type: ignore[assignment]
    if seen_again:
        threading.Timer(0.1, lambda: setattr(frames, "world", world("confirmed"))).start()
    before = len(logged(run))
    found = run._look_again("P-3").get("P-3")
    assert found is not None and found.state == ("confirmed" if seen_again else "lost")
    assert logged(run)[before:] == [f"looked again at P-3: {'seen' if seen_again else 'still not seen'}"]


def test_a_track_in_view_is_judged_at_once(run: MissionRun) -> None:
    now = world("confirmed")
    run.loop = Frames(now)  # type: ignore[assignment]
    before = len(logged(run))
    assert run._look_again("P-3") is now and run._look_again("P-99") is now and len(logged(run)) == before
