"""A tracker's state carried across a stop: restored from its JSON, it goes on exactly as the tracker that never
stopped (same ids, stillness clocks, new ids numbered after the old), and a state that does not hold together is
refused, not half-loaded."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from agentic_core.perception.pipeline import Perception
from agentic_core.perception.tracker import TrackerState

from .synthetic import SyntheticScene, run

HOME = (21.4133, 39.8933, 300.0)


def test_a_restored_tracker_goes_on_as_if_it_never_stopped() -> None:
    frames = list(run(SyntheticScene(seed=4, walkers=12, still=6), 90))
    going, stopped = Perception(home=HOME), Perception(home=HOME)
    for frame, detections, _ in frames[:45]:
        going.update(frame, detections)
        stopped.update(frame, detections)
    saved = TrackerState.model_validate_json(stopped.tracker_state().model_dump_json())
    resumed = Perception(home=HOME)
    resumed.restore_tracks(saved)
    for frame, detections, _ in frames[45:]:
        expected = going.update(frame, detections)
        got = resumed.update(frame, detections)
        assert [o.id for o in got.objects] == [o.id for o in expected.objects]
        assert [o.stationary_s for o in got.objects] == [o.stationary_s for o in expected.objects]
    a, b = going.tracks, resumed.tracks
    assert a is not None and b is not None and a.ids == b.ids
    np.testing.assert_array_equal(a.x, b.x)
    np.testing.assert_array_equal(a.state, b.state)
    assert max(b.stationary_s) > 2.0  # the still ones kept counting across the stop


def test_new_tracks_after_a_restore_are_numbered_after_the_old_ones() -> None:
    frames = list(run(SyntheticScene(seed=5, walkers=4, still=2), 30))
    first = Perception(home=HOME)
    for frame, detections, _ in frames[:15]:
        first.update(frame, detections)
    state = first.tracker_state()
    resumed = Perception(home=HOME)
    resumed.restore_tracks(state)
    (frame, detections, _) = frames[0]
    far = frame.model_copy(update={"time_s": frames[14][0].time_s + 60.0, "index": 999})
    resumed.update(far, detections)  # a minute later, the walkers are elsewhere: new tracks
    tracks = resumed.tracks
    assert tracks is not None
    new = [i for i in tracks.ids if i not in state.ids]
    assert new and all(int(i.split("-")[1]) > state.counters["P"] for i in new)


@pytest.mark.parametrize(
    "change",
    [
        {"ids": ["P-01", "P-02"]},  # two ids, one row of everything else
        {"cls": [7]},  # a class that was never named
        {"state": [5]},
        {"P": [[[1.0, 0.0], [0.0, 1.0]]]},  # not 4×4
    ],
    ids=["rows", "class", "state", "covariance"],
)
def test_a_state_that_does_not_hold_together_is_refused(change: dict[str, object]) -> None:
    frames = list(run(SyntheticScene(seed=6, walkers=1, still=0), 5))
    perception = Perception(home=HOME)
    for frame, detections, _ in frames:
        perception.update(frame, detections)
    good = perception.tracker_state().model_dump()
    assert len(good["ids"]) == 1
    with pytest.raises(ValidationError):
        TrackerState.model_validate({**good, **change})
