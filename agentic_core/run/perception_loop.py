"""Perception alongside the flight: at every telemetry sample, a camera frame when one is due, its detections,
and the World Model brought up to date.

The camera's pose is the one the vehicle reports in its telemetry (:class:`~agentic_core.contracts.TelemetrySample`),
not simulator truth, so the same loop serves the in-process simulator (samples in lockstep, in the vehicle's
thread: frames at the camera's rate in *simulated* time whatever the speed) and a vehicle over a MAVLink link
(samples as they arrive, in the client's thread). The mission reads :attr:`PerceptionLoop.world`, the latest
model, from its own thread. The scene moves with the frames (the detector advances it). With ``render=True`` the
frames carry rendered pixels (:func:`~flight.sim.render.camera.rendering_camera`, 640×480), so an alert's picture
is the view.

>>> from flight.sim.scene_file import load_scene
>>> loop = PerceptionLoop(load_scene("scenes/hajj_normal.yaml"), seed=1)
>>> loop.frames, loop.world.objects  # before the first tick: an empty world at home
(0, [])

``vehicle.on_telemetry.append(loop.on_sample)`` runs it with the simulated vehicle.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Mapping
from pathlib import Path

from agentic_core.contracts.geodesy import local_offset
from flight.camera import CameraPose, Frame
from flight.sim.detector import SimulatedCamera, SimulatedDetector
from flight.sim.render.camera import rendering_camera
from flight.sim.scene_model import Scene
from flight.sim.simulator import VehicleState

from ..contracts import TelemetrySample
from ..perception.pipeline import Perception, PerceptionConfig
from ..perception.tracker import TrackerState
from ..perception.world_model import WorldModel
from .detector_choice import needs_pixels, pixel_detector

REID_RADIUS_M = 8.0
"""How far from where a dropped track was last seen a new track may be taken for the same object."""


class PerceptionLoop:
    """The simulated camera and detector over a scene, feeding :class:`Perception`."""

    def __init__(
        self,
        scene: Scene,
        *,
        seed: int = 0,
        camera: SimulatedCamera | None = None,
        config: PerceptionConfig | None = None,
        render: bool = False,
        detector: str = "sim",
    ) -> None:
        self.scene = scene
        home = scene.home
        self.home = (home.lat_deg, home.lon_deg, home.alt_msl_m)
        self.camera = camera or SimulatedCamera()
        self.detector = SimulatedDetector(scene, seed=seed)
        if render or needs_pixels(detector):  # pixels, of the scene the detector moves (flight.sim.render)
            self.camera = rendering_camera(self.detector.state, seed, like=self.camera)
        self.pixels = pixel_detector(detector, self.detector, seed=seed)
        """A real detector on the rendered frames (``--detector ours|onnx:PATH``), else None: the simulated one."""
        self.perception = Perception(home=self.home, config=config, landmarks=[*scene.landmarks, *scene.zones])
        self.frames = 0
        self.busy_s = 0.0
        """Wall time spent in perception (camera, detector, tracker, relations, contract)."""
        self.sensor_s = 0.0
        """Of which the simulated camera and detector: the scene moving and the detector standing in for YOLO,
        not the perception pipeline's own work."""
        self.last_sensor_s = 0.0
        self.last_pipeline_s = 0.0
        """The last frame's split: simulated sensing, then tracker, relations and contract."""
        self.first_detected: dict[str, float] = {}
        """Simulated time each ground-truth actor was first detected (for time-to-intervention)."""
        self._lock = threading.Lock()
        self._world: WorldModel | None = None
        self.restored: WorldModel | None = None
        self.on_world: list[Callable[[WorldModel], None]] = []
        """Called with each new World Model, in the thread that took the frame (the watch looks here)."""
        self._last_seen: dict[str, tuple[float, float, str, float]] = {}
        """Every object id seen: where it was last, its class, and when (for targets and re-identification)."""

    def on_sample(self, sample: TelemetrySample) -> None:
        """A telemetry sample arrived: take a frame from the pose it reports, if one is due at its time."""
        if self.camera.due(sample.time_s):
            pose = CameraPose(
                north_m=sample.north_m, east_m=sample.east_m, down_m=sample.down_m,
                roll_rad=math.radians(sample.roll_deg), pitch_rad=math.radians(sample.pitch_deg),
                yaw_rad=math.radians(sample.yaw_deg),
            )  # fmt: skip
            self.observe(pose, sample.time_s)

    def restore(
        self,
        world: WorldModel,
        last_seen: Mapping[str, tuple[float, float, str, float]] | None = None,
        tracks: TrackerState | None = None,
    ) -> None:
        """Start from a World Model saved before (a resumed run): it stands until the first new frame, and the
        objects it knows, or that were seen before it (``last_seen``: a stop flew the aircraft away from them), can
        still be found as targets after that; with the tracker's ``tracks``, the same people go on under the same
        ids with their stillness clocks (a casualty still for 8 s before the stop is not judged afresh)."""
        if tracks is not None:
            self.perception.restore_tracks(tracks)
        with self._lock:
            self._world = world
            self.restored = world
            self._last_seen.update(last_seen or {})

    def tracker_state(self) -> TrackerState:
        """The tracker's tracks now, for a snapshot."""
        return self.perception.tracker_state()

    def last_seen(self) -> dict[str, tuple[float, float, str, float]]:
        """Where each object was last seen (latitude, longitude, class, time), for a snapshot."""
        return dict(self._last_seen)

    def target(self, object_id: str) -> tuple[float, float] | None:
        """Where an object is (latitude, longitude): in the World Model now, else where it was last seen (a track
        dropped a moment ago, or one only a restored model knows)."""
        found = self.world.get(object_id)
        if found is not None:
            return found.pose.lat, found.pose.lon
        last = self._last_seen.get(object_id)
        if last is not None:
            return last[0], last[1]
        old = self.restored.get(object_id) if self.restored is not None else None
        return (old.pose.lat, old.pose.lon) if old is not None else None

    def resolve(self, object_id: str, within_m: float = REID_RADIUS_M) -> str | None:
        """The id an object has in the World Model now: its own while it is tracked; when its track was dropped,
        the object of its class nearest to where it was last seen (within ``within_m``) whose track began after
        that (the tracker gave it a new id); None when there is none."""
        world = self.world
        if world.get(object_id) is not None:
            return object_id
        last = self._last_seen.get(object_id)
        if last is None:
            return None
        lat, lon, class_name, seen_s = last
        best: tuple[float, str] | None = None
        for obj in world.objects:
            born_s = world.timestamp - obj.track_age_frames * self.camera.spec.frame_period_s
            if obj.class_name != class_name or born_s < seen_s - 1.0:
                continue
            north, east = local_offset(lat, lon, obj.pose.lat, obj.pose.lon)
            gap = math.hypot(north, east)
            if gap <= within_m and (best is None or gap < best[0]):
                best = (gap, obj.id)
        return best[1] if best is not None else None

    def observe(self, source: VehicleState | CameraPose, time_s: float | None = None) -> WorldModel:
        """Take one frame from a vehicle state (or a camera pose at ``time_s``) and bring the World Model up to
        date with it; returns the new model."""
        start = time.perf_counter()
        frame = self.camera.capture(source, time_s)
        if self.pixels is not None:
            frame, detections = self.pixels.see(frame)
        else:
            detections = self.detector.detect(frame)
        sensed = time.perf_counter()
        world = self.perception.update(frame, detections)
        done = time.perf_counter()
        for detection in detections:
            if detection.truth_id is not None:
                self.first_detected.setdefault(detection.truth_id, frame.time_s)
        ids, lats, lons, classes = self.perception.placed
        when = [frame.time_s] * len(ids)
        self._last_seen.update(zip(ids, zip(lats, lons, classes, when, strict=True), strict=True))
        with self._lock:
            self._world = world
            self.frames += 1
            self.busy_s += done - start
            self.sensor_s += sensed - start
            self.last_sensor_s, self.last_pipeline_s = sensed - start, done - sensed
        for hook in self.on_world:
            hook(world)
        return world

    def warm(self, width_px: int = 640) -> None:
        """Draw one (empty) picture now, so the first alert does not pay for loading the annotator and its glyphs."""
        from ..perception.annotate import annotate_frame

        frame = Frame(index=0, time_s=0.0, spec=self.camera.spec, pose=CameraPose(north_m=0, east_m=0, down_m=-30))
        annotate_frame(frame, self.world, width_px=width_px)

    @property
    def world(self) -> WorldModel:
        """The latest World Model (an empty one, at the home position, before the first frame)."""
        with self._lock:
            if self._world is not None:
                return self._world
        lat, lon, alt = self.home
        return WorldModel.model_validate(
            {"timestamp": 0.0, "ego_pose": {"north": 0, "east": 0, "down": 0, "lat": lat, "lon": lon, "alt": alt}}
        )

    def snapshot(self, path: Path, width_px: int = 640) -> Path | None:
        """The last frame annotated, as a PNG at ``path`` (640 px wide: enough for an alert, and quick to draw);
        ``None`` before the first frame."""
        with self._lock:
            if self._world is None:
                return None
            self.perception.snapshot(path, width_px=width_px)
        return path


__all__ = ["PerceptionLoop"]
