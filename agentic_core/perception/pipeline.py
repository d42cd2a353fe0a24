"""One perception update: a frame's detections → ground measurements → tracks → scene graph → World Model.

:class:`Perception` keeps the tracker and the scene graph across frames; call :meth:`Perception.update` once per
camera frame (30 Hz) with that frame's detections and read the :class:`~.world_model.WorldModel` it returns (also
kept as :attr:`Perception.world`). One thread updates; others may read :attr:`Perception.world` or take a
:meth:`Perception.snapshot` meanwhile and see one frame's state, never a mix of two. The world model lists
confirmed tracks and lost ones still within their re-identification window (``state`` says which); tentative
tracks only with ``publish_tentative``.

>>> from agentic_core.contracts.camera import BoundingBox, CameraPose, CameraSpec, Detection, Frame
>>> from agentic_core.contracts.pinhole import project_points
>>> spec, pose = CameraSpec(), CameraPose(north_m=0.0, east_m=0.0, down_m=-30.0)
>>> perception = Perception(home=(21.4133, 39.8933, 0.0))
>>> (u, v), = project_points(spec, pose, np.array([[4.0, 3.0, -0.85]]))[0]  # a person's middle, 0.85 m up
>>> box = BoundingBox(x_min=u - 15, y_min=v - 15, x_max=u + 15, y_max=v + 15)
>>> for k in range(12):  # someone motionless, 12 frames at 30 Hz
...     world = perception.update(Frame(index=k, time_s=k / 30, spec=spec, pose=pose),
...                               [Detection(class_name="person", box=box, confidence=0.89)])
>>> [(o.id, o.state, o.track_age_frames, round(o.pose.north, 2)) for o in world.objects]
[('P-01', 'confirmed', 12, 4.0)]
>>> sorted(r.pred for r in world.relations_of("P-01"))
['isolated_from', 'stationary']
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from agentic_core.contracts.camera import BoundingBox, Detection, Frame
from agentic_core.contracts.geodesy import earth_radii, ned_to_geodetic
from agentic_core.contracts.pinhole import footprint

from .measurement import NoiseModel, common_covariance, ego_covariance, ground_measurements
from .scene_graph import Rel, RelationConfig, SceneGraph, as_landmark
from .tracker import STATE_NAMES, TENTATIVE, Tracker, TrackerConfig, TrackerState, TrackTable
from .world_model import Landmark, Relation, WorldModel, WorldObject, trusted_objects, trusted_relations

STAGES = ("measure", "track", "relations", "contract")
"""The stages :attr:`Perception.timings` reports, in order."""


class PerceptionConfig(BaseModel):
    """Everything perception assumes and decides by: sensor noise, tracking, relation thresholds."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    noise: NoiseModel = Field(default_factory=NoiseModel)
    tracker: TrackerConfig = Field(default_factory=TrackerConfig)
    relations: RelationConfig = Field(default_factory=RelationConfig)
    publish_tentative: bool = Field(default=False, description="list tentative tracks in the world model too")


class Perception:
    """Detections in, World Model out, frame after frame (see the module docs).

    ``home`` is the local frame's origin as (latitude, longitude, altitude m); ``landmarks`` are records of the
    shapes :func:`.scene_graph.as_landmark` reads.
    """

    def __init__(
        self,
        *,
        home: tuple[float, float, float],
        config: PerceptionConfig | None = None,
        landmarks: Iterable[Any] = (),
    ) -> None:
        self.config = config or PerceptionConfig()
        self.home = home
        self.tracker = Tracker(self.config.tracker)
        self._tracking = threading.Lock()  # held while the tracker steps, so its state is read whole
        self.scene_graph = SceneGraph(self.config.relations)
        self.landmarks: list[Landmark] = []
        self.set_landmarks(landmarks)
        self._last: tuple[Frame, list[Detection], TrackTable, WorldModel] | None = None
        self.timings: dict[str, float] = dict.fromkeys(STAGES, 0.0)
        """Seconds each stage took in the last update."""
        self.placed: tuple[list[str], list[float], list[float], list[str]] = ([], [], [], [])
        """The last published model's objects as columns (ids, latitudes, longitudes, classes), in its order: for
        per-frame bookkeeping over hundreds of objects without reading each record (in the updating thread)."""

    def set_landmarks(self, landmarks: Iterable[Any]) -> None:
        """Replace the known landmarks (and zones); their lat/lon are filled in from home."""
        lat0, lon0, _ = self.home
        out = []
        for record in landmarks:
            lm = as_landmark(record)
            lat, lon = _geodetic(lat0, lon0, np.array([lm.north]), np.array([lm.east]))
            out.append(lm.model_copy(update={"lat": float(lat[0]), "lon": float(lon[0])}))
        self.landmarks = out

    def update(self, frame: Frame, detections: Sequence[Detection]) -> WorldModel:
        """Take in one frame's detections; returns (and keeps) the world model at the frame's time."""
        cfg = self.config
        t0 = time.perf_counter()
        measurements = ground_measurements(frame, detections, cfg.noise)
        corners = footprint(frame.spec, frame.pose, cfg.noise.ground_down_m)
        lift = cfg.noise.centre_height_m.get("person", 0.0)  # a person is in sight when their middle is
        sight = footprint(frame.spec, frame.pose, cfg.noise.ground_down_m - lift) if lift else corners
        t1 = time.perf_counter()
        with self._tracking:
            tracks = self.tracker.step(frame.time_s, measurements, sight)
        t2 = time.perf_counter()
        ego = {"north": frame.pose.north_m, "east": frame.pose.east_m, "down": frame.pose.down_m, "time": frame.time_s}
        relations = self.scene_graph.update(tracks, landmarks=self.landmarks, footprint=corners, ego=ego)
        t3 = time.perf_counter()
        world = self.contract(frame, tracks, relations)
        self._last = (frame, list(detections), tracks, world)  # one assignment: readers see one frame's state
        t4 = time.perf_counter()
        self.timings = dict(zip(STAGES, (t1 - t0, t2 - t1, t3 - t2, t4 - t3), strict=True))
        return world

    def tracker_state(self) -> TrackerState:
        """The tracker's tracks and id counters now, whole (safe from any thread): for a run's snapshot."""
        with self._tracking:
            return self.tracker.state()

    def restore_tracks(self, state: TrackerState) -> None:
        """Go on from tracks saved by :meth:`tracker_state` (a resumed run)."""
        with self._tracking:
            self.tracker.restore(state)

    @property
    def world(self) -> WorldModel | None:
        """The world model of the last update (``None`` before the first)."""
        return None if self._last is None else self._last[3]

    @property
    def tracks(self) -> TrackTable | None:
        """The tracker's tracks after the last update."""
        return None if self._last is None else self._last[2]

    @property
    def frame(self) -> Frame | None:
        """The last frame taken in."""
        return None if self._last is None else self._last[0]

    @property
    def detections(self) -> list[Detection]:
        """The last frame's detections."""
        return [] if self._last is None else self._last[1]

    def track_boxes(self, tracks: TrackTable | None = None) -> dict[str, BoundingBox]:
        """The pixel box of every track detected in the last frame (or in ``tracks``), by track id."""
        tracks = tracks or self.tracks
        if tracks is None:
            return {}
        return {
            tracks.ids[k]: BoundingBox(x_min=b[0], y_min=b[1], x_max=b[2], y_max=b[3])
            for k, b in zip(np.flatnonzero(tracks.detected), tracks.boxes[tracks.detected].tolist(), strict=True)
        }

    def snapshot(self, path: str | Path | None = None, *, width_px: int = 960) -> bytes:
        """The last frame annotated (:func:`.annotate.annotate_frame`) as PNG bytes, also written to ``path``."""
        last = self._last  # read once: another thread may be updating
        if last is None:
            raise RuntimeError("no frame yet: call update() first")
        from .annotate import annotate_frame  # matplotlib: loaded when a picture is first wanted

        frame, detections, tracks, world = last
        boxes = self.track_boxes(tracks)
        return annotate_frame(frame, world, detections=detections, boxes=boxes, path=path, width_px=width_px)

    def contract(
        self, frame: Frame, tracks: TrackTable, relations: Sequence[Rel], *, validate: bool = False
    ) -> WorldModel:
        """The World Model of these tracks and relations at this frame (what :meth:`update` publishes).

        The records of the objects and relations, hundreds each a frame, are not validated one by one: one check
        on the arrays first proves every bound the contract puts on them (every float finite, latitude and
        longitude in range, ``conf`` in 0–1, ``stationary_s`` and the track age not negative, ids and names
        strings), and they are then built from values of exactly the types validation gives
        (:func:`.world_model.trusted_objects`, :func:`.world_model.trusted_relations`). Should anything fail
        that check (a NaN that slipped through), those records are validated instead, which refuses it with
        pydantic's ``ValidationError`` as before. The rest (time, ego pose, health, landmarks, and the model
        around the records) is validated as always. ``validate=True`` validates every record: the reference the
        tests hold the published model equal to.
        """
        cfg = self.config
        lat0, lon0, alt0 = self.home
        shown = tracks.state != TENTATIVE if not cfg.publish_tentative else np.ones(len(tracks), dtype=bool)
        rows = np.flatnonzero(shown)
        picked = rows.tolist()
        x = tracks.x[rows].astype(float, copy=False)
        lat, lon = _geodetic(lat0, lon0, x[:, 0], x[:, 1])
        cov = tracks.P[rows, :2, :2] + common_covariance(cfg.noise, frame.health, frame.pose, x[:, :2])
        speed = np.hypot(x[:, 2], x[:, 3])
        conf = tracks.conf[rows].astype(float, copy=False)
        still = tracks.stationary_s[rows].astype(float, copy=False)
        seen = tracks.last_seen[rows].astype(float, copy=False)
        age = tracks.age_frames[rows]
        ids = [tracks.ids[r] for r in picked]
        classes = [tracks.classes[r] for r in picked]
        down = float(cfg.noise.ground_down_m)
        alt = float(alt0 - down)
        lats, lons = lat.tolist(), lon.tolist()
        columns = zip(
            ids,
            classes,
            x.tolist(),
            lats,
            lons,
            speed.tolist(),
            conf.tolist(),
            cov.reshape(-1, 4).astype(float, copy=False).tolist(),
            age.tolist(),
            still.tolist(),
            [STATE_NAMES[s] for s in tracks.state[rows].tolist()],
            seen.tolist(),
            strict=True,
        )
        within = (
            bool(np.isfinite(np.concatenate([x.ravel(), cov.ravel(), lat, lon, conf, still, seen, [down, alt]])).all())
            and bool((np.abs(lat) <= 90.0).all() and (np.abs(lon) <= 180.0).all())
            and bool(((conf >= 0.0) & (conf <= 1.0)).all() and (still >= 0.0).all())
            and age.dtype.kind in "iu"
            and bool((age >= 0).all())
            and all(type(v) is str for v in ids)
            and all(type(v) is str for v in classes)
        )
        objects: list[WorldObject] | list[dict[str, Any]]
        if within and not validate:
            objects = trusted_objects(columns, down=down, alt=alt)
        else:
            objects = [
                {
                    "id": ident,
                    "class": cls,
                    "pose": {"north": n, "east": e, "down": down, "lat": la, "lon": lo, "alt": alt},
                    "vel": {"north": vn, "east": ve, "down": 0.0, "speed": sp},
                    "conf": cf,
                    "cov": [[c00, c01], [c10, c11]],
                    "track_age_frames": ag,
                    "stationary_s": st,
                    "state": state,
                    "last_seen": sn,
                }
                for ident, cls, (n, e, vn, ve), la, lo, sp, cf, (c00, c01, c10, c11), ag, st, state, sn in columns
            ]
        records: list[Relation] | list[dict[str, Any]]
        if not validate and all(_trusted_relation(r) for r in relations):
            records = trusted_relations(relations)
        else:
            records = [r._asdict() for r in relations]
        pose = frame.pose
        e_lat, e_lon, e_alt = ned_to_geodetic(pose.north_m, pose.east_m, pose.down_m, lat0, lon0, alt0)
        ego = {
            "north": pose.north_m,
            "east": pose.east_m,
            "down": pose.down_m,
            "lat": e_lat,
            "lon": e_lon,
            "alt": e_alt,
            "roll_deg": math.degrees(pose.roll_rad),
            "pitch_deg": math.degrees(pose.pitch_rad),
            "yaw_deg": math.degrees(pose.yaw_rad),
            "cov": ego_covariance(cfg.noise, frame.health).tolist(),
        }
        degraded = frame.health.degraded
        world = WorldModel.model_validate(
            {
                "timestamp": frame.time_s,
                "frame": frame.index,
                "ego_pose": ego,
                "objects": objects,
                "relations": records,
                "health": {"degraded_sensors": sorted(degraded), "factors": dict(sorted(degraded.items()))},
                "landmarks": self.landmarks,
            }
        )
        self.placed = (ids, lats, lons, classes)
        return world


def _trusted_relation(r: Rel) -> bool:
    """Whether a relation's values are what validating them would give: strings, and a finite ``float`` or none."""
    subj, pred, obj, value = r
    return (
        type(subj) is str
        and type(pred) is str
        and (obj is None or type(obj) is str)
        and (value is None or (type(value) is float and math.isfinite(value)))
    )


def _geodetic(lat0: float, lon0: float, north: np.ndarray, east: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Latitudes and longitudes of local points (the tangent plane of :mod:`agentic_core.contracts.geodesy`,
    vectorised)."""
    r_m, r_n = earth_radii(lat0)
    lat = lat0 + np.degrees(north / r_m)
    lon = lon0 + np.degrees(east / (r_n * math.cos(math.radians(lat0))))
    return lat, lon
