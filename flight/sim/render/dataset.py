"""Labelled frames for training and testing a person detector: rendered views of randomised scenes, with the
exact pixel box and pose of every person they show.

Each scene (one per :data:`VIEWS_PER_SCENE` frames) is drawn from the seed: a walkway crossing the area in any
direction (paved or asphalt, 10–30 m wide) crowded at 0.05–1.5 persons/m², sometimes a plaza and a tent camp;
a crowd mix with plenty of lying persons (resting: 15–40 %, besides walking, standing and sitting); 0–3
collapsed persons near the centre; tents, awnings, a medical post, water, a parked vehicle, each some of the
time. Clothing is mostly white. Each view looks down from an altitude drawn from ``altitudes_m`` (height above
the ground), at any heading, with the gimbal tilted up to 12° from straight down, over a point within 25 m of the
scene's centre.

A label is a person's box clipped to the image (the projected extent of legs, body and head; shadows excluded),
their pose (``standing``, ``walking``, ``sitting``, ``lying``) and the share of them a camera sees (``visible``):
the share of their box inside the image times the share of their drawn pixels no person drawn after them covers
(exact, from the renderer's drawing order). Persons seen less than :data:`MIN_SEEN` are still labelled, so a
detector that finds them is not blamed, but are neither trained on nor counted in recall: they are *ignored*, as
KITTI and COCO ignore heavily occluded and crowd boxes. Persons not seen at all, or whose clipped box is under
:data:`MIN_SIZE_PX` pixels on its longer side, are left out of the labels (they are still drawn).

>>> frames = list(labelled_frames(seed=3, count=2, altitudes_m=(30,), width=160, height=120))
>>> [f.image.shape for f in frames], frames[0].altitude_m
([(120, 160, 3), (120, 160, 3)], 30.0)
>>> frames[0].boxes.dtype.name, len(frames[0].poses) == len(frames[0].boxes) == len(frames[0].visible)
('float32', True)
>>> bool(((frames[0].visible > 0) & (frames[0].visible <= 1)).all())
True
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from agentic_core.contracts.camera import CameraPose, CameraSpec
from flight.sim.scene_model import NE, Actor, Circle, GroundTruth, Landmark, Scene, Zone

from .renderer import SceneRenderer

MIN_SEEN = 0.5
"""A person seen less than this (:attr:`LabelledFrame.visible`) is ignored: neither a target nor a false alarm."""
MIN_SIZE_PX = 3.0
VIEWS_PER_SCENE = 4
HFOV_DEG = 84.0


@dataclass(frozen=True)
class LabelledFrame:
    """One rendered frame and its labels: boxes (K×4 float32 x0, y0, x1, y1 pixels, clipped to the image), each
    box's pose, the camera's height above the ground, and the share of each person seen (0–1)."""

    image: NDArray[np.uint8]
    boxes: NDArray[np.float32]
    poses: tuple[str, ...]
    altitude_m: float
    visible: NDArray[np.float32]


def labelled_frames(
    seed: int,
    count: int,
    *,
    altitudes_m: Sequence[float] = (10, 20, 30, 40, 50, 60),
    width: int = 640,
    height: int = 480,
    start: int = 0,
) -> Iterator[LabelledFrame]:
    """``count`` labelled frames, the same for the same arguments; from frame ``start`` on (a multiple of
    :data:`VIEWS_PER_SCENE`, where a scene begins), so that parts of one series can be rendered apart."""
    if count < 0:
        raise ValueError(f"count must be >= 0, got {count}")
    if start < 0 or start % VIEWS_PER_SCENE:
        raise ValueError(f"start must be a multiple of {VIEWS_PER_SCENE} from 0, got {start}")
    if not altitudes_m:
        raise ValueError("altitudes_m must name at least one altitude")
    renderer: SceneRenderer | None = None
    for k in range(start, start + count):
        if k % VIEWS_PER_SCENE == 0:
            renderer = SceneRenderer(random_scene(seed, k // VIEWS_PER_SCENE), seed=seed)
        assert renderer is not None
        rng = np.random.default_rng([seed, 93, k])
        altitude = float(altitudes_m[int(rng.integers(0, len(altitudes_m)))])
        spec = CameraSpec(
            width_px=width, height_px=height, hfov_deg=HFOV_DEG, gimbal_pitch_deg=-90.0 + float(rng.uniform(0, 12))
        )
        north, east = rng.uniform(-25.0, 25.0, 2)
        pose = CameraPose(
            north_m=float(north), east_m=float(east), down_m=-altitude, yaw_rad=float(rng.uniform(-math.pi, math.pi))
        )
        out = renderer.render(spec, pose, frame_index=k, occlusion=True)
        p = out.persons
        assert p.shown is not None
        seen = p.visible * p.shown
        size = np.maximum(p.boxes[:, 2] - p.boxes[:, 0], p.boxes[:, 3] - p.boxes[:, 1])
        keep = np.flatnonzero((seen > 0) & (size >= MIN_SIZE_PX))
        yield LabelledFrame(
            image=out.image,
            boxes=p.boxes[keep].astype(np.float32).reshape(-1, 4),
            poses=tuple(p.poses[i] for i in keep),
            altitude_m=altitude,
            visible=seen[keep].astype(np.float32),
        )


def random_scene(seed: int, index: int) -> Scene:
    """The ``index``-th randomised training scene of ``seed`` (see the module docs)."""
    rng = np.random.default_rng([seed, 91, index])
    turn = float(rng.uniform(0.0, math.pi))
    width = float(rng.uniform(10.0, 30.0))
    offset = float(rng.uniform(-15.0, 15.0))
    walkway = _strip(turn, offset - width / 2, offset + width / 2, 120.0)
    resting = float(rng.uniform(0.15, 0.4))
    mix = {"walking": 0.5, "standing": 0.25, "sitting": 0.15, "resting": resting}
    zones = [
        Zone(id="Z-walk", kind="walkway", polygon=_ne(walkway), density=float(rng.uniform(0.05, 1.5)), mix=mix)
    ]  # fmt: skip
    landmarks: list[Landmark] = []
    if rng.random() < 0.5:
        landmarks.append(Landmark(id="Road-1", kind="road", polygon=_ne(walkway)))
    side = 1.0 if rng.random() < 0.5 else -1.0
    far = offset + side * (width / 2 + 8.0)
    if rng.random() < 0.5:
        centre = _rotate(turn, float(rng.uniform(-30, 30)), far + side * 12.0)
        zones.append(
            Zone(
                id="Z-plaza", kind="plaza", circle=Circle(center=NE(north=centre[0], east=centre[1]), radius_m=10.0),
                density=float(rng.uniform(0.1, 1.0)), mix={"standing": 0.4, "sitting": 0.3, "resting": 0.3},
            )
        )  # fmt: skip
    if rng.random() < 0.5:
        camp = _strip(turn, -offset - side * 60.0, -offset - side * 20.0, 100.0)
        zones.append(
            Zone(
                id="Z-camp", kind="camp", polygon=_ne(camp), density=float(rng.uniform(0.02, 0.2)),
                mix={"standing": 0.3, "sitting": 0.3, "walking": 0.1, "resting": 0.3},
            )
        )  # fmt: skip
    for j in range(int(rng.integers(0, 5))):
        at = _rotate(turn, float(rng.uniform(-40, 40)), float(rng.uniform(-40, 40)))
        kind = ("tent", "tent", "medical_post", "water", "gate")[int(rng.integers(0, 5))]
        landmarks.append(Landmark(id=f"L-{j}", kind=kind, position=NE(north=at[0], east=at[1])))
    for j in range(int(rng.integers(0, 3))):
        at = _rotate(turn, float(rng.uniform(-30, 30)), far + side * float(rng.uniform(0, 6)))
        square = [(at[0] + dn, at[1] + de) for dn, de in ((-4, -4), (4, -4), (4, 4), (-4, 4))]
        landmarks.append(Landmark(id=f"Shade-{j}", kind="shade", polygon=_ne(np.array(square))))
    actors: list[Actor] = []
    for j in range(int(rng.integers(0, 4))):
        spot = rng.uniform(-25.0, 25.0, 2)
        actors.append(
            Actor(id=f"P-C{j}", behaviour="collapsed", position=NE(north=float(spot[0]), east=float(spot[1])),
                  heading_deg=float(rng.uniform(0, 360)))
        )  # fmt: skip
    if rng.random() < 0.3:
        at = _rotate(turn, float(rng.uniform(-30, 30)), far)
        actors.append(
            Actor(id="V-1", class_name="vehicle", behaviour="parked", position=NE(north=at[0], east=at[1]),
                  heading_deg=math.degrees(turn))
        )  # fmt: skip
    casualties = [a.id for a in actors if a.behaviour == "collapsed"]
    truth = GroundTruth(expected_severity="high" if casualties else "none", casualties=casualties)
    return Scene(
        id=f"train-{seed}-{index}",
        seed=int(rng.integers(0, 2**31)),
        actors=actors,
        zones=zones,
        landmarks=landmarks,
        ground_truth=truth,
    )


def _rotate(turn: float, along: float, across: float) -> tuple[float, float]:
    c, s = math.cos(turn), math.sin(turn)
    return along * c - across * s, along * s + across * c


def _strip(turn: float, lo: float, hi: float, length: float) -> NDArray[np.float64]:
    """A rectangle ``length`` long along the heading ``turn``, from ``lo`` to ``hi`` across it (north/east)."""
    half = length / 2
    return np.array([_rotate(turn, a, b) for a, b in ((-half, lo), (half, lo), (half, hi), (-half, hi))])


def _ne(points: NDArray[np.float64]) -> list[NE]:
    return [NE(north=float(n), east=float(e)) for n, e in points]


__all__ = ["MIN_SEEN", "MIN_SIZE_PX", "VIEWS_PER_SCENE", "LabelledFrame", "labelled_frames", "random_scene"]
