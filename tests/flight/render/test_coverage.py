"""How much of each person a frame shows, from the renderer's own drawing order: a person nobody covers is seen
whole, a person under a crowd is seen barely, asking for it changes no pixel, and the dataset's visible share is
the in-image share times the uncovered share."""

from __future__ import annotations

import numpy as np

from agentic_core.contracts.camera import CameraPose, CameraSpec
from flight.sim.render import SceneRenderer
from flight.sim.render.coverage import Coverage
from flight.sim.scene_model import NE, Actor, GroundTruth, Scene

SPEC = CameraSpec(width_px=320, height_px=240)
DOWN = CameraPose(north_m=0.0, east_m=0.0, down_m=-15.0)


def _scene(*actors: tuple[str, str, float, float]) -> Scene:
    people = [
        Actor.model_validate({"id": i, "behaviour": b, "position": NE(north=n, east=e), "heading_deg": 0.0})
        for i, b, n, e in actors
    ]
    casualties = [a.id for a in people if a.behaviour == "collapsed"]
    truth = GroundTruth(expected_severity="high" if casualties else "none", casualties=casualties)
    return Scene(id="cover", seed=5, actors=people, ground_truth=truth)


def _shown(scene: Scene, pose: CameraPose = DOWN) -> dict[str, float]:
    out = SceneRenderer(scene, seed=1).render(SPEC, pose, occlusion=True).persons
    assert out.shown is not None
    return dict(zip(out.ids, out.shown.tolist(), strict=True))


def test_a_person_nobody_covers_is_seen_whole() -> None:
    assert _shown(_scene(("P-1", "collapsed", 0.0, 0.0))) == {"P-1": 1.0}


def test_a_lying_person_under_a_standing_crowd_is_barely_seen() -> None:
    crowd = [(f"S-{k}", "standing", n, 0.0) for k, n in enumerate((-0.8, -0.45, -0.1, 0.25, 0.5, 0.73))]
    shown = _shown(_scene(("P-1", "collapsed", 0.0, 0.0), *crowd))
    assert shown["P-1"] < 0.3, shown
    top = [shown[f"S-{k}"] for k in range(len(crowd))]
    assert min(top) > 0.4, shown  # standing on top, each mostly seen (neighbours' heads cover a little)


def test_asking_for_coverage_changes_no_pixel() -> None:
    scene = _scene(("P-1", "collapsed", 0.0, 0.0), ("S-1", "standing", 0.2, 0.1), ("S-2", "sitting", -1.0, 0.3))
    plain = SceneRenderer(scene, seed=1).render(SPEC, DOWN)
    counted = SceneRenderer(scene, seed=1).render(SPEC, DOWN, occlusion=True)
    assert plain.persons.shown is None and counted.persons.shown is not None
    assert np.array_equal(plain.image, counted.image)
    assert np.array_equal(plain.persons.boxes, counted.persons.boxes)


def test_a_person_half_out_of_the_image_is_not_counted_as_covered() -> None:
    scene = _scene(("P-1", "collapsed", 0.0, 0.0))
    edge = SceneRenderer(scene, seed=1).render(SPEC, DOWN).persons.full_boxes[0]
    shift = (edge[2] + edge[0]) / 2 - SPEC.width_px  # put the person's centre on the right edge
    pose = DOWN.model_copy(update={"east_m": float(shift) * 15.0 / SPEC.focal_px})
    out = SceneRenderer(scene, seed=1).render(SPEC, pose, occlusion=True).persons
    assert out.shown is not None and out.shown[0] == 1.0
    assert 0.2 < out.visible[0] < 0.8


def test_later_paint_takes_the_pixel_and_an_empty_footprint_is_unseen() -> None:
    cover = Coverage(3, 2)
    cover.paint(np.array([0, 1, 1]), np.array([0, 0, 1]))
    assert cover.owner.tolist() == [0, 1, -1, -1, -1, -1]
    assert cover.shown_share(3).tolist() == [0.5, 1.0, 0.0]
