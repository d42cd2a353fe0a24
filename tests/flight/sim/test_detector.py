"""The simulated camera and detector: geometry of the boxes, and detection statistics that match the documented model.

Every test is seeded, so each runs the same numbers every time; the tolerances say how far a correct model could
stray from its expectation over the samples drawn (a few standard errors), so a failure means the model changed.
"""

import itertools
import math
from pathlib import Path

import numpy as np
import pytest

from flight.camera import CameraPose, CameraSpec, Detection, Detector, SensorHealth, ground_points
from flight.sim.detector import DetectionModel, SimulatedCamera, SimulatedDetector, visibility_factor
from flight.sim.scene import SceneState
from flight.sim.scene_file import load_scene
from flight.sim.scene_gen import generate_scene
from flight.sim.scene_model import NE, Actor, GroundTruth, Scene, Zone
from flight.sim.simulator import VehicleState

REPO_SCENES = Path(__file__).resolve().parents[3] / "scenes"


def grid_scene(side=8, spacing=3.5, behaviour="standing", class_name="person", zones=(), seed=0):
    """``side``×``side`` actors ``spacing`` m apart around home: no crowd, no occlusion, nobody near anybody."""
    half = (side - 1) * spacing / 2
    actors = [
        Actor(
            id=f"A-{i}-{j}",
            class_name=class_name,
            behaviour=behaviour,
            position=NE(north=i * spacing - half, east=j * spacing - half),
        )
        for i in range(side)
        for j in range(side)
    ]
    lying = behaviour == "collapsed"  # casualties, every one of them; none isolated
    truth = GroundTruth(expected_severity="high", casualties=[a.id for a in actors]) if lying else GroundTruth()
    return Scene(id="grid", seed=seed, actors=actors, zones=list(zones), ground_truth=truth)


def nadir(altitude, north=0.0, east=0.0):
    return CameraPose(north_m=north, east_m=east, down_m=-altitude)


def run(detector, pose, frames, health=None, start=0):
    camera = SimulatedCamera(health=health)
    camera.frames_taken = start
    return [detector.detect(camera.capture(pose, time_s=(start + k) / 30.0)) for k in range(frames)]


QUIET = {"false_positives_per_frame": 0.0, "background_false_positives_per_frame": 0.0}


def test_it_is_a_detector_and_repeats_itself_from_the_seed():
    scene = load_scene(REPO_SCENES / "hajj_emergency.yaml")
    first = SimulatedDetector(scene, seed=5)
    assert isinstance(first, Detector)
    pose = nadir(30.0, north=150.0)
    a, b = run(first, pose, 20), run(SimulatedDetector(scene, seed=5), pose, 20)
    assert a == b
    assert a != run(SimulatedDetector(scene, seed=6), pose, 20)
    # the detections are ordinary, valid Detection models (built without re-validation for speed)
    for d in a[0][:50]:
        assert Detection.model_validate(d.model_dump(by_alias=True)) == d
    assert [d.confidence for d in a[0]] == sorted((d.confidence for d in a[0]), reverse=True)


def test_detections_built_unvalidated_are_the_validated_records_field_for_field():
    """The detector makes hundreds of Detection records a frame without validating them (a quarter of the cost):
    each must be what validation gives, in values and their types, in the fields set, in JSON, frozen as any, and
    copy-on-change must give ordinary records."""
    scene = load_scene(REPO_SCENES / "hajj_emergency.yaml")
    frames = run(SimulatedDetector(scene, seed=2), nadir(30.0, north=150.0), 10)
    built = [d for frame in frames for d in frame]
    assert any(d.truth_id is None for d in built) and any(d.truth_id is not None for d in built)  # both kinds
    for d in built:
        valid = Detection.model_validate(d.model_dump(by_alias=True))
        assert d == valid and d.box == valid.box
        assert d.model_fields_set == valid.model_fields_set and d.box.model_fields_set == valid.box.model_fields_set
        assert d.model_dump_json() == valid.model_dump_json()
        assert [type(v) for v in d.box.__dict__.values()] == [float] * 4 and type(d.confidence) is float
    first = built[0]
    with pytest.raises(ValueError, match="frozen"):
        first.confidence = 0.5
    changed = first.model_copy(update={"confidence": 0.25})
    assert changed.confidence == 0.25 and first.confidence != 0.25
    assert type(changed.model_fields_set) is set


def test_boxes_land_where_the_actors_are():
    scene = grid_scene(side=6, spacing=4.0)
    model = DetectionModel(jitter_px=0.0, jitter_fraction=0.0, **QUIET)
    detector = SimulatedDetector(scene, model=model)
    spec, pose = CameraSpec(), nadir(30.0, north=1.0, east=-2.0)
    frames = run(detector, pose, 5)
    state = detector.state
    checked = 0
    for detections in frames:
        for d in detections:
            truth = state.positions[state.index_of(d.truth_id)]
            # the box's centre is the body's middle: cast back onto the plane at half its height (0.85 m) it is
            # within centimetres of the actor; onto the ground, within the lean of a 1.7 m body seen 10 m off-axis
            centre = np.array([d.box.center])
            at_mid, _ = ground_points(spec, pose, centre, ground_down_m=-0.85)
            on_ground, _ = ground_points(spec, pose, centre)
            assert np.linalg.norm(at_mid[0] - truth) < 0.15
            assert np.linalg.norm(on_ground[0] - truth) < 1.0
            checked += 1
    assert checked > 100
    jittered = SimulatedDetector(scene, model=DetectionModel(**QUIET))
    for d in run(jittered, pose, 3)[-1]:
        on_ground, _ = ground_points(spec, pose, np.array([d.box.center]), ground_down_m=-0.85)
        assert np.linalg.norm(on_ground[0] - state.positions[state.index_of(d.truth_id)]) < 0.3  # ~1 px at 28 mm/px


def test_boxes_stay_in_the_image_and_mostly_hidden_actors_are_dropped():
    spec = CameraSpec()
    half_width = 30.0 * math.tan(math.radians(spec.hfov_deg / 2))  # the view's east edge on the ground
    actors = [
        Actor(id="IN", position=NE(north=0, east=half_width - 2.0)),
        Actor(id="EDGE", position=NE(north=0, east=half_width + 0.2)),  # less than half of it in view
        Actor(id="OUT", position=NE(north=0, east=half_width + 5.0)),
    ]
    detector = SimulatedDetector(Scene(id="edge", actors=actors), model=DetectionModel(**QUIET))
    view = detector.in_view(SimulatedCamera().capture(nadir(30.0)))
    assert view.ids == ["IN"]
    assert (view.boxes[:, [0, 2]] <= spec.width_px).all() and (view.boxes >= 0).all()
    for detections in run(detector, nadir(30.0), 30):
        for d in detections:
            assert 0 <= d.box.x_min <= d.box.x_max <= spec.width_px
            assert 0 <= d.box.y_min <= d.box.y_max <= spec.height_px


def test_mean_person_confidence_is_the_papers_yolo_figure():
    """64 people seen for 300 frames: ~18,000 confidences, beta with sd 0.12, standard error 0.001. The model's mean
    at fine GSD is 0.72 less 0.25(1 - f_size) ≈ 0.0003; ±0.01 is ten standard errors and still brackets the paper's
    0.716."""
    detector = SimulatedDetector(grid_scene(), model=DetectionModel(**QUIET), seed=3)
    confidences = np.array([d.confidence for frame in run(detector, nadir(30.0), 300) for d in frame])
    assert len(confidences) > 15_000
    assert confidences.mean() == pytest.approx(0.72, abs=0.01)
    assert confidences.std() == pytest.approx(math.sqrt(0.72 * 0.28 / 13), abs=0.01)  # Beta(μκ, (1-μ)κ), κ = 12
    assert confidences.min() >= 0.25


def test_vehicles_have_their_own_confidence():
    detector = SimulatedDetector(grid_scene(side=4, spacing=8.0, class_name="vehicle", behaviour="parked"), seed=1)
    detections = [d for frame in run(detector, nadir(40.0), 200) for d in frame if d.truth_id]
    assert {d.class_name for d in detections} == {"vehicle"}
    assert np.mean([d.confidence for d in detections]) == pytest.approx(0.80, abs=0.015)  # ~3,000 draws, se 0.002


def test_hit_rate_matches_the_documented_probability():
    """The chain's long-run hit rate is p. 64 actors × 400 frames with persistence 0.6 are worth about a quarter
    as many independent draws (6,400): standard error under 0.006 at p ≈ 0.95, so ±0.02."""
    detector = SimulatedDetector(grid_scene(), model=DetectionModel(**QUIET), seed=8)
    camera, pose = SimulatedCamera(), nadir(30.0)
    hits, expected = 0, 0.0
    for k in range(400):
        frame = camera.capture(pose, time_s=k / 30.0)
        expected += detector.in_view(frame).p_detect.sum()
        hits += len(detector.detect(frame))
    assert hits / expected == pytest.approx(1.0, abs=0.02)
    assert 0.90 < expected / (400 * 64) < 0.96  # p_max 0.95 × f_size ≈ 1 for 18-px people


def test_recall_falls_with_altitude():
    """People 3.5 m apart under a camera climbing from 30 to 120 m (18, 9, 6 and 4.5 px across from straight
    above): the model's p is about 0.95, 0.83, 0.42 and 0.19 (8-px people are found half the time). 100 frames × 64
    people per altitude, worth ~1,600 independent draws with persistence 0.6, leave standard errors near 0.012, so
    each step down must be over 0.1."""
    scene = grid_scene()
    recall = []
    for altitude in (30.0, 60.0, 90.0, 120.0):
        detector = SimulatedDetector(scene, model=DetectionModel(**QUIET), seed=4)
        found = sum(len(frame) for frame in run(detector, nadir(altitude), 100))
        recall.append(found / (100 * 64))
    assert all(a - b > 0.1 for a, b in itertools.pairwise(recall)), recall
    assert recall[0] > 0.9 and recall[-1] < 0.3


def test_misses_come_in_runs():
    """Per actor, the lag-one autocorrelation of hits is the chain's persistence (0.6), or 0 without it. At 70 m the
    people are ~10 px and p ≈ 0.7, so both hits and misses are common; 64 series of 400 frames give a standard error
    near 0.01 on the mean autocorrelation, hence ±0.06."""
    scene = grid_scene()

    def autocorrelation(persistence):
        detector = SimulatedDetector(scene, model=DetectionModel(persistence=persistence, **QUIET), seed=2)
        ids = [a.id for a in scene.actors]
        series = np.zeros((len(ids), 400))
        for k, frame in enumerate(run(detector, nadir(70.0), 400)):
            hit = {d.truth_id for d in frame}
            series[:, k] = [ident in hit for ident in ids]
        rates = series.mean(axis=1)
        assert 0.3 < rates.mean() < 0.8
        centred = series - rates[:, None]
        lag1 = (centred[:, 1:] * centred[:, :-1]).mean(axis=1) / centred.var(axis=1)
        return float(lag1.mean())

    assert autocorrelation(0.6) == pytest.approx(0.6, abs=0.06)
    assert autocorrelation(0.0) == pytest.approx(0.0, abs=0.06)


def test_false_positives_come_at_the_configured_rate_in_crowds_only():
    """A sparse crowd zone (0.002 persons/m²) under the whole view: candidates at 2 per frame all count. Over 1,000
    frames the mean of a Poisson(2) has standard error 0.045, so ±0.15."""
    square = [NE(north=-300, east=-300), NE(north=300, east=-300), NE(north=300, east=300), NE(north=-300, east=300)]
    crowd = Zone(id="Z", polygon=square, density=0.002, mix={"standing": 1.0})
    model = DetectionModel(false_positives_per_frame=2.0, background_false_positives_per_frame=0.0)
    detector = SimulatedDetector(Scene(id="fp", zones=[crowd]), model=model, seed=9)
    false = [d for frame in run(detector, nadir(30.0), 1000) for d in frame if d.truth_id is None]
    assert len(false) / 1000 == pytest.approx(2.0, abs=0.15)
    assert {d.class_name for d in false} == {"person"}
    # confidence 0.25 + 0.75·Beta(2, 8): mean 0.40, sd 0.09; ~2,000 draws, standard error 0.002
    assert np.mean([d.confidence for d in false]) == pytest.approx(0.40, abs=0.01)
    assert min(d.confidence for d in false) >= 0.25
    # outside every crowd zone only the background rate remains: here zero
    empty = SimulatedDetector(grid_scene(side=2), model=model, seed=9)
    assert all(d.truth_id is not None for frame in run(empty, nadir(30.0), 200) for d in frame)


def test_crowds_occlusion_and_lying_down_lower_p():
    sparse = SimulatedDetector(grid_scene(), model=DetectionModel(**QUIET))
    dense_zone = Zone(
        id="Z",
        polygon=[NE(north=-20, east=-30), NE(north=20, east=-30), NE(north=20, east=30), NE(north=-20, east=30)],
        density=3.0,
        mix={"standing": 1.0},
    )
    dense = SimulatedDetector(Scene(id="dense", zones=[dense_zone]), model=DetectionModel(**QUIET))
    frame = SimulatedCamera().capture(nadir(30.0))
    a, b = sparse.in_view(frame), dense.in_view(frame)
    assert a.density.max() == 0.0 and a.occlusion.max() == 0.0
    assert b.density.mean() == pytest.approx(3.0, rel=0.25)  # persons/m² within 2 m, counted around each one
    assert b.occlusion.mean() > 0.05
    assert b.p_detect.mean() < 0.8 * a.p_detect.mean()
    assert b.confidence_mean.mean() < a.confidence_mean.mean()
    lying = SimulatedDetector(grid_scene(behaviour="collapsed"), model=DetectionModel(**QUIET)).in_view(frame)
    assert lying.size_px.mean() > a.size_px.mean()  # from straight above a lying body is the larger one,
    assert lying.p_detect.mean() == pytest.approx(0.8 * a.p_detect.mean(), rel=0.02)  # but detectors like it less


def test_degraded_sensors_lower_detection_and_raise_jitter():
    """A camera degraded ×2 halves p (k = 2) and doubles the box jitter; thermal ×4 counts as camera ×2."""
    scene = grid_scene()
    pose = nadir(30.0)
    assert visibility_factor(SensorHealth(degraded={"thermal": 4.0})) == 2.0
    assert visibility_factor(SensorHealth(degraded={"gps": 4.0})) == 1.0  # GPS is reported, not seen

    def stats(health):
        detector = SimulatedDetector(scene, model=DetectionModel(**QUIET), seed=12)
        camera = SimulatedCamera(health=health)
        errors, hits = [], 0
        for k in range(200):
            frame = camera.capture(pose, time_s=k / 30.0)
            assert frame.health == health
            exact = dict(zip(detector.in_view(frame).ids, detector.in_view(frame).boxes, strict=True))
            for d in detector.detect(frame):
                hits += 1
                errors.append(np.array([d.box.x_min, d.box.y_min, d.box.x_max, d.box.y_max]) - exact[str(d.truth_id)])
        return hits / (200 * 64), float(np.std(errors))

    healthy_rate, healthy_jitter = stats(SensorHealth())
    for health in (SensorHealth(degraded={"camera": 2.0}), SensorHealth(degraded={"thermal": 4.0})):
        rate, jitter = stats(health)
        assert rate == pytest.approx(healthy_rate / 2, rel=0.1)  # ~6,000 trials each: se under 2 %
        assert jitter / healthy_jitter == pytest.approx(2.0, rel=0.1)  # ~25,000 edge errors each


def test_the_camera_runs_at_30_hz_from_the_vehicle():
    fields: dict[str, object] = {name: 0.0 for name in VehicleState.model_fields}
    fields.update(armed=True, landed=False, payload_released=False, setpoint="HoldPosition")
    state = VehicleState(**{**fields, "time_s": 12.5, "north_m": 150.0, "down_m": -30.0, "yaw_rad": 0.3})
    camera = SimulatedCamera(health=lambda t: SensorHealth(degraded={"thermal": 2.0}) if t > 10 else SensorHealth())
    assert camera.due(0.0)
    frame = camera.capture(state)
    assert frame.time_s == 12.5 and frame.index == 0 and frame.image is None
    assert frame.pose == CameraPose(north_m=150.0, east_m=0.0, down_m=-30.0, yaw_rad=0.3)
    assert frame.health.degraded == {"thermal": 2.0}
    assert not camera.due(12.5 + 1 / 60) and camera.due(12.5 + 1 / 30)
    assert camera.capture(nadir(30.0), time_s=13.0).index == 1


def test_the_emergency_scene_from_the_missions_leg():
    """Flying the first leg of missions/hajj_emergency.yaml (north along east 0 at 30 m, 8 m/s) past P-12: it is
    seen for many frames running, as in the paper (12 frames), with confidence around 0.72, while the road's
    crowd fills the rest of the view."""
    scene = load_scene(REPO_SCENES / "hajj_emergency.yaml")
    detector = SimulatedDetector(scene, seed=1)
    camera = SimulatedCamera()
    run_length, longest, confidences, crowd = 0, 0, [], []
    for k in range(150):  # 5 s: from 20 m before P-12 to 20 m past it
        t = k / 30.0
        frame = camera.capture(nadir(30.0, north=130.0 + 8.0 * t), time_s=t)
        detections = detector.detect(frame)
        casualty = [d for d in detections if d.truth_id == "P-12"]
        run_length = run_length + 1 if casualty else 0
        longest = max(longest, run_length)
        confidences += [d.confidence for d in casualty]
        crowd.append(len(detections))
    assert longest >= 12
    assert 0.6 < np.mean(confidences) < 0.8
    assert min(crowd) > 50


def test_a_thousand_persons_in_view():
    scene = generate_scene(3, persons=6000, casualties=1, distractors=4)
    detector = SimulatedDetector(SceneState(scene), seed=0)
    frame = SimulatedCamera().capture(nadir(60.0, east=scene.zones[0].vertices()[:, 1].mean()))
    view = detector.in_view(frame)
    assert len(view.rows) >= 1000
    detections = detector.detect(frame)
    assert len([d for d in detections if d.truth_id]) == pytest.approx(view.p_detect.sum(), rel=0.1)
