"""Perception alongside the flight: at every vehicle tick, a camera frame when one is due, its detections, and the
World Model brought up to date.

The loop runs in the simulated vehicle's thread (it is the vehicle's tick hook), so frames are taken at the
camera's rate in *simulated* time whatever the speed of the run; the mission reads :attr:`PerceptionLoop.world`,
the latest model, from its own thread. The scene moves with the frames (the detector advances it).

>>> from flight.sim.scene_file import load_scene
>>> loop = PerceptionLoop(load_scene("scenes/hajj_normal.yaml"), seed=1)
>>> loop.frames, loop.world.objects  # before the first tick: an empty world at home
(0, [])

``vehicle.on_tick.append(loop.on_tick)`` runs it with the simulated vehicle.
"""

from __future__ import annotations

import threading
import time
from pathlib import Path

from flight.camera import CameraPose, Frame
from flight.sim.detector import SimulatedCamera, SimulatedDetector
from flight.sim.scene_model import Scene
from flight.sim.simulator import VehicleState

from ..perception.pipeline import Perception, PerceptionConfig
from ..perception.world_model import WorldModel


class PerceptionLoop:
    """The simulated camera and detector over a scene, feeding :class:`Perception`."""

    def __init__(
        self,
        scene: Scene,
        *,
        seed: int = 0,
        camera: SimulatedCamera | None = None,
        config: PerceptionConfig | None = None,
    ) -> None:
        self.scene = scene
        home = scene.home
        self.home = (home.lat_deg, home.lon_deg, home.alt_msl_m)
        self.camera = camera or SimulatedCamera()
        self.detector = SimulatedDetector(scene, seed=seed)
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

    def on_tick(self, state: VehicleState) -> None:
        """The vehicle's tick hook: take a frame if one is due at the vehicle's time."""
        if self.camera.due(state.time_s):
            self.observe(state)

    def observe(self, source: VehicleState | CameraPose, time_s: float | None = None) -> WorldModel:
        """Take one frame from a vehicle state (or a camera pose at ``time_s``) and bring the World Model up to
        date with it; returns the new model."""
        start = time.perf_counter()
        frame = self.camera.capture(source, time_s)
        detections = self.detector.detect(frame)
        sensed = time.perf_counter()
        world = self.perception.update(frame, detections)
        done = time.perf_counter()
        for detection in detections:
            if detection.truth_id is not None:
                self.first_detected.setdefault(detection.truth_id, frame.time_s)
        with self._lock:
            self._world = world
            self.frames += 1
            self.busy_s += done - start
            self.sensor_s += sensed - start
            self.last_sensor_s, self.last_pipeline_s = sensed - start, done - sensed
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
