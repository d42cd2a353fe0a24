"""The camera that renders: a scene seen from a camera pose as an RGB frame, with the exact pixel box of every
person it shows.

Assembly, in order: the ground (:class:`~flight.sim.render.ground.GroundMap`: zones, landmarks, sky), the
shadows, vehicles, then people layer by layer (legs, bodies, heads; farther ones first within a layer), then the
sensor (:class:`~flight.sim.render.sensor.Sensor`: motion blur from the camera's velocity, exposure wobble,
noise). A person's box is the projected extent of their drawn body (legs, body, head; not the shadow), before
clipping (``full_boxes``) and clipped to the image (``boxes``), with the share of it inside the image
(``visible``) and, when asked (``occlusion=True``), the share of their drawn pixels in the image no one drawn after
them covers (``shown``, from the drawing order itself: :class:`~flight.sim.render.coverage.Coverage`). A camera at
or below the ground is drawn as if 5 cm above it.

>>> from flight.sim.scene_file import load_scene
>>> from agentic_core.contracts.camera import CameraPose, CameraSpec
>>> renderer = SceneRenderer(load_scene("scenes/hajj_emergency.yaml"), seed=1)
>>> out = renderer.render(CameraSpec(width_px=640, height_px=480), CameraPose(north_m=150, east_m=10, down_m=-30))
>>> out.image.shape, "P-12" in out.persons.ids
((480, 640, 3), True)
>>> out.persons.poses[out.persons.ids.index("P-12")]
'lying'
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from agentic_core.contracts.camera import CameraPose, CameraSpec, Frame
from agentic_core.contracts.pinhole import ground_points, project_points, rotation_world_from_camera
from flight.sim.scene import SceneState
from flight.sim.scene_model import Scene

from .bodies import BODY_LAYER, POSES, SHADOW_LAYER, Looks, person_parts, pose_codes, sun_offset, vehicle_quads
from .coverage import Coverage
from .ground import MIN_HEIGHT_M, GroundMap
from .palette import SHADE_FACTOR
from .raster import capsule_boxes, draw_capsules, draw_quads
from .sensor import Sensor

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
NEAR_M = 0.05
"""Parts nearer the camera than this (along its axis) are not drawn."""


@dataclass(frozen=True)
class PersonView:
    """The persons a frame shows, one row each: scene rows and ids, pixel boxes (x0, y0, x1, y1) clipped to the
    image and unclipped, the share of each unclipped box inside the image, each one's pose (:data:`POSES`) and,
    when the frame was rendered with ``occlusion=True``, the share of each one's drawn pixels left uncovered."""

    rows: IntArray
    ids: list[str]
    boxes: FloatArray
    full_boxes: FloatArray
    visible: FloatArray
    poses: tuple[str, ...]
    shown: FloatArray | None = None


@dataclass(frozen=True)
class Rendered:
    """One rendered frame: H×W×3 uint8 pixels and the persons in it."""

    image: NDArray[np.uint8]
    persons: PersonView


class SceneRenderer:
    """Renders one scene (or a :class:`SceneState` shared with the simulated detector). Not thread-safe."""

    def __init__(self, scene: Scene | SceneState, *, seed: int = 0, sensor: Sensor | None = None) -> None:
        self.state = scene if isinstance(scene, SceneState) else SceneState(scene)
        self.ground = GroundMap(self.state.scene)
        self.looks = Looks(self.state, seed)
        self.sun = sun_offset(self.state.scene.seed)
        self.sensor = sensor or Sensor(seed)
        self._poses = pose_codes(self.state)

    def render_frame(self, frame: Frame, velocity_ned: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> Rendered:
        """:meth:`render` for a :class:`Frame` (its spec, pose, time and index)."""
        return self.render(
            frame.spec, frame.pose, time_s=frame.time_s, frame_index=frame.index, velocity_ned=velocity_ned
        )

    def render(
        self,
        spec: CameraSpec,
        pose: CameraPose,
        *,
        time_s: float | None = None,
        frame_index: int = 0,
        velocity_ned: tuple[float, float, float] = (0.0, 0.0, 0.0),
        occlusion: bool = False,
    ) -> Rendered:
        """The frame ``spec`` takes from ``pose`` (the scene advanced to ``time_s`` first, when given); with
        ``occlusion``, each person's uncovered share too (``PersonView.shown``; it costs a few ms)."""
        if time_s is not None:
            self.state.advance_to(time_s)
        if pose.down_m > -MIN_HEIGHT_M:
            pose = pose.model_copy(update={"down_m": -MIN_HEIGHT_M})
        image = self.ground.view(spec, pose)
        rows = self.state.in_sight(spec, pose)
        camera = _Camera(spec, pose)
        vehicles = rows[self._poses[rows] < 0]
        if len(vehicles):
            self._draw_vehicles(image, camera, vehicles)
        people = rows[self._poses[rows] >= 0]
        cover = Coverage(spec.width_px, spec.height_px) if occlusion else None
        persons = self._draw_people(image, camera, people, cover)
        blur = _blur_px(spec, pose, velocity_ned, self.sensor.exposure_s)
        return Rendered(self.sensor.expose(image, frame_index, blur), persons)

    def _draw_vehicles(self, image: NDArray[np.uint8], camera: _Camera, rows: IntArray) -> None:
        shadow, shadow_far, roof, screen, paint = vehicle_quads(self.state, rows, self.looks, self.sun)
        for quads, rgb in (
            (shadow_far, None),
            (shadow, None),
            (roof, paint),
            (screen, np.tile([[40.0, 48.0, 56.0]], (len(rows), 1))),
        ):
            pixels, ok = camera.project(quads.reshape(-1, 3))
            pixels[~ok] = np.nan
            if rgb is None:  # shadows darken the ground beneath
                mean = image.reshape(-1, 3).mean(axis=0) * SHADE_FACTOR
                rgb = np.tile(mean, (len(rows), 1))
            draw_quads(image, pixels.reshape(len(rows), 4, 2), rgb)

    def _draw_people(
        self, image: NDArray[np.uint8], camera: _Camera, rows: IntArray, cover: Coverage | None = None
    ) -> PersonView:
        spec = camera.spec
        parts = person_parts(self.state, rows, self.looks, self.sun)
        a_px, a_ok = camera.project(parts.a)
        b_px, b_ok = camera.project(parts.b)
        depth = np.minimum(camera.depth(parts.a), camera.depth(parts.b))
        ok = a_ok & b_ok
        radius = np.where(ok, parts.radius * spec.focal_px / np.maximum(depth, NEAR_M), 0.0)
        for layer in range(SHADOW_LAYER, BODY_LAYER + 2):
            sel = np.flatnonzero(ok & (parts.layer == layer))
            sel = sel[np.argsort(-depth[sel], kind="stable")]
            for mode in np.unique(parts.mode[sel]):
                m = sel[parts.mode[sel] == mode]
                owned = None if cover is None or layer == SHADOW_LAYER else (cover, parts.owner[m])
                draw_capsules(image, a_px[m], b_px[m], radius[m], parts.rgb[m], int(mode), owned)
        body = ok & (parts.layer != SHADOW_LAYER)
        shown = np.zeros(len(rows), dtype=bool)
        shown[parts.owner[parts.layer == BODY_LAYER][ok[parts.layer == BODY_LAYER]]] = True
        full = np.tile(np.array([np.inf, np.inf, -np.inf, -np.inf]), (len(rows), 1))
        boxes = capsule_boxes(a_px[body], b_px[body], radius[body])
        owner = parts.owner[body]
        np.minimum.at(full[:, 0], owner, boxes[:, 0])
        np.minimum.at(full[:, 1], owner, boxes[:, 1])
        np.maximum.at(full[:, 2], owner, boxes[:, 2])
        np.maximum.at(full[:, 3], owner, boxes[:, 3])
        clipped = np.column_stack(
            [
                np.clip(full[:, 0], 0, spec.width_px),
                np.clip(full[:, 1], 0, spec.height_px),
                np.clip(full[:, 2], 0, spec.width_px),
                np.clip(full[:, 3], 0, spec.height_px),
            ]
        )
        with np.errstate(invalid="ignore"):
            area = (full[:, 2] - full[:, 0]) * (full[:, 3] - full[:, 1])
            seen = np.clip(clipped[:, 2] - clipped[:, 0], 0, None) * np.clip(clipped[:, 3] - clipped[:, 1], 0, None)
            visible = np.where(area > 0, seen / np.where(area > 0, area, 1.0), 0.0)
        keep = np.flatnonzero(shown & (visible > 0))
        codes = self._poses[rows[keep]]
        return PersonView(
            rows=rows[keep],
            ids=[self.state.ids[i] for i in rows[keep]],
            boxes=clipped[keep],
            full_boxes=full[keep],
            visible=visible[keep],
            poses=tuple(POSES[c] for c in codes),
            shown=None if cover is None else cover.shown_share(len(rows))[keep],
        )


class _Camera:
    """World points to pixels and depths for one frame (the pinhole contract's model, with depths kept)."""

    def __init__(self, spec: CameraSpec, pose: CameraPose) -> None:
        self.spec = spec
        self.pose = pose
        self.rotation = rotation_world_from_camera(spec, pose)

    def depth(self, points: FloatArray) -> FloatArray:
        d: FloatArray = (points - self.pose.position) @ self.rotation[:, 2]
        return d

    def project(self, points: FloatArray) -> tuple[FloatArray, NDArray[np.bool_]]:
        """Pixels of N points and which lie in front of the camera (at least :data:`NEAR_M`)."""
        pixels, _ = project_points(self.spec, self.pose, points)
        ok = (self.depth(points) >= NEAR_M) & ~np.isnan(pixels).any(axis=1)
        return pixels, ok


def _blur_px(
    spec: CameraSpec, pose: CameraPose, velocity: tuple[float, float, float], exposure_s: float
) -> tuple[float, float]:
    """How far the ground at the image centre moves in the image while the shutter is open."""
    if not any(velocity):
        return 0.0, 0.0
    centre = np.array([spec.principal_point])
    ground, hit = ground_points(spec, pose, centre)
    if not hit[0]:
        return 0.0, 0.0
    point = np.array([[ground[0, 0], ground[0, 1], 0.0]])
    moved = pose.model_copy(
        update={
            "north_m": pose.north_m + velocity[0] * exposure_s,
            "east_m": pose.east_m + velocity[1] * exposure_s,
            "down_m": min(pose.down_m + velocity[2] * exposure_s, -MIN_HEIGHT_M),
        }
    )
    before, _ = project_points(spec, pose, point)
    after, _ = project_points(spec, moved, point)
    shift = after[0] - before[0]
    if np.isnan(shift).any():
        return 0.0, 0.0
    return float(shift[0]), float(shift[1])


__all__ = ["PersonView", "Rendered", "SceneRenderer"]
