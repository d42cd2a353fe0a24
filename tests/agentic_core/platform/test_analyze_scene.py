"""The run's ``perception.analyze_scene`` tool, as the mission calls it: an assessment under the step's
``min_confidence`` is looked at again before it fails the step, and when it fails, the agent sees an error that
says so (a result, not a crash). The run is assembled, not flown: the reasoner and the clock are the test's."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from agentic_core.agent import Gate
from agentic_core.run.runner import MissionRun, RunSettings

from ..agent.fakes import Events, FakeVehicle, FakeWorld, Unsure, person, world_of
from .conftest import EMERGENCY, NEAR, PARAMS

pytestmark = pytest.mark.timeout(60)


@pytest.fixture
def run(tmp_path: Path) -> Iterator[MissionRun]:
    made = MissionRun(RunSettings(mission=EMERGENCY, scene=NEAR, runs_dir=tmp_path / "runs", params=PARAMS))
    yield made
    made.close()


def judged_by(run: MissionRun, reasoner: Unsure) -> Events:
    events = Events()
    run.gate = Gate(reasoner, FakeWorld(world_of(person("P-1"))), FakeVehicle(step_s=0.01), events.publish, run.pace,
                    look_again_s=0.2)  # fmt: skip
    return events


def test_a_moment_of_doubt_does_not_fail_the_confirmation(run: MissionRun) -> None:
    reasoner = Unsure([0.46, 0.83])
    events = judged_by(run, reasoner)
    result = run.executor.call("perception.analyze_scene", {"focus": "P-1", "min_confidence": 0.5})
    assert result.status == "ok", result.error
    assert isinstance(result.output, dict) and result.output["assessment"]["confidence"] == 0.83
    assert len(reasoner.at) == 2 and len(events.of("decision")) == 2


def test_a_doubt_that_stays_fails_the_step_with_an_error_saying_so(run: MissionRun) -> None:
    reasoner = Unsure([0.46, 0.31])
    judged_by(run, reasoner)
    result = run.executor.call("perception.analyze_scene", {"focus": "P-1", "min_confidence": 0.5})
    assert result.status == "error" and len(reasoner.at) == 2
    assert result.error is not None
    assert "confidence 0.31 is below the required 0.50, also after looking again for 0.2 s" in result.error
