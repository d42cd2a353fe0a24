"""Multi-target tracking on the ground plane: ground measurements in, tracks with identities out.

Each frame: predict every track to the frame's time (:mod:`.kalman`), match detections to tracks
(:mod:`.association`), correct the matched tracks, start a tentative track on every detection left over, and
run each track's life cycle:

* **tentative → confirmed** when it was detected in ``confirm_hits`` of its last ``confirm_window`` frames
  (3 of 5: a person is confirmed on their third frame, 0.1 s at 30 Hz, while a one-frame false positive never is);
* a tentative track that can no longer reach that is dropped;
* **confirmed → lost** after ``lost_after_misses`` frames in a row without a detection (coasting meanwhile), or
  at once when it is predicted outside the camera's footprint (out of sight is not a miss); a lost track keeps
  its id for ``reid_window_s`` and takes it back if it is detected again (a person the drone looks away from and
  back at), after which it is deleted;
* a lost track that had been seen motionless for ``dormant_after_still_s`` or more instead goes *dormant* after
  ``reid_window_s``: it stays where it was (neither its position nor its uncertainty is predicted on), is listed
  nowhere (not in :meth:`Tracker.table`, so neither in the scene graph nor the World Model), and takes its id and
  stillness clock back if it is detected there again within ``dormant_window_s`` (a collapsed person the drone
  flew away from, and came back to after a stop); a motionless person out of sight is most likely where they were.

Stillness: a track is *clearly moving* when its filtered speed is more than ``moving_sigmas`` standard deviations
above ``still_speed_mps``; or its mean velocity since its stillness began is (the distance from where it began,
less ``moving_sigmas`` deviations of that distance, exceeds ``still_speed_mps`` times the time since: this catches
a walker within about 0.3 s, sooner than the filtered velocity settles); or it has crept more than
``still_radius_m`` from there. Any of these resets its stillness clock. ``stationary_s`` is the time from the
start of stillness (at the earliest, the track's first frame) to its last detection: how long it has been
*observed* motionless. A track born still therefore starts counting on its first frame; a gap in observation
does not reset it if it is found again at the same spot.

The tracker never sees ``Detection.truth_id``: it gets :class:`.measurement.Measurements`.

>>> tracker = Tracker()
>>> R = np.array([np.eye(2) * 0.01])
>>> for k in range(4):
...     table = tracker.step(k / 30, Measurements(z=np.array([[5.0, 2.0]]), R=R, classes=["person"],
...                          conf=np.array([0.9]), boxes=np.zeros((1, 4)), index=np.array([0])))
>>> table.ids, table.state_names(), table.age_frames.tolist(), round(float(table.stationary_s[0]), 3)
(['P-01'], ['confirmed'], [4], 0.1)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict, Field, model_validator

from agentic_core.contracts.polygon import points_in_polygon

from . import kalman
from .association import associate
from .measurement import Measurements

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

TENTATIVE, CONFIRMED, LOST = 0, 1, 2
STATE_NAMES = ("tentative", "confirmed", "lost")
_POPCOUNT = np.array([bin(i).count("1") for i in range(256)], dtype=np.int64)
_PREFIX = {"person": "P", "vehicle": "V", "car": "V", "truck": "V", "bicycle": "B", "animal": "A"}


class TrackerConfig(BaseModel):
    """How the tracker trusts motion, matches detections and manages track lives (see the module docs)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    q: float = Field(default=0.1, gt=0, description="white-acceleration spectral density, m²/s³ (pedestrians)")
    birth_speed_sigma: float = Field(default=1.5, gt=0, description="velocity std of a new track, m/s")
    gate: float = Field(default=13.8, gt=0, description="squared Mahalanobis gate (chi² 2 dof, 99.9 %)")
    max_gate_m: float = Field(default=5.0, gt=0, description="no gate wider than this, however uncertain")
    confirm_hits: int = Field(default=3, ge=1, le=8)
    confirm_window: int = Field(default=5, ge=1, le=8)
    lost_after_misses: int = Field(default=10, ge=1, description="frames without a detection before 'lost'")
    reid_window_s: float = Field(default=3.0, ge=0, description="how long a lost track keeps its id")
    dormant_after_still_s: float = Field(
        default=2.0, ge=0, description="seen motionless this long, a lost track goes dormant instead of being deleted"
    )
    dormant_window_s: float = Field(default=600.0, ge=0, description="how long a dormant track keeps its id")
    still_speed_mps: float = Field(default=0.3, gt=0, description="faster than this (clearly) is moving")
    still_radius_m: float = Field(default=1.0, gt=0, description="drifting farther than this is moving")
    moving_sigmas: float = Field(default=2.0, ge=0, description="how clearly the speed must exceed the bound")
    conf_smoothing: float = Field(default=0.3, gt=0, le=1, description="weight of the newest detection's conf")


class TrackerState(BaseModel):
    """Every track and id counter of a :class:`Tracker` at one moment, as plain lists: what a stopped run keeps
    so that, resumed, it goes on tracking the same people under the same ids with the same stillness clocks."""

    model_config = ConfigDict(extra="forbid")

    time_s: float | None = None
    classes: list[str] = Field(default_factory=list, description="class names in the order they were first seen")
    counters: dict[str, int] = Field(default_factory=dict, description="the last number given per id prefix")
    ids: list[str] = Field(default_factory=list)
    cls: list[int] = Field(default_factory=list)
    state: list[int] = Field(default_factory=list)
    x: list[tuple[float, float, float, float]] = Field(default_factory=list)
    P: list[list[list[float]]] = Field(default_factory=list)
    hist: list[int] = Field(default_factory=list)
    misses: list[int] = Field(default_factory=list)
    age: list[int] = Field(default_factory=list)
    last_seen: list[float] = Field(default_factory=list)
    still_since: list[float] = Field(default_factory=list)
    anchor: list[tuple[float, float]] = Field(default_factory=list)
    anchor_var: list[float] = Field(default_factory=list)
    conf: list[float] = Field(default_factory=list)
    boxes: list[tuple[float, float, float, float]] = Field(default_factory=list)

    @model_validator(mode="after")
    def _one_row_per_track(self) -> TrackerState:
        n = len(self.ids)
        for name in _ROWS:
            if len(getattr(self, name)) != n:
                raise ValueError(f"{name} has {len(getattr(self, name))} rows for {n} tracks")
        if any(c < 0 or c >= len(self.classes) for c in self.cls) or any(s not in (0, 1, 2) for s in self.state):
            raise ValueError("a track's class or state is out of range")
        if any(np.shape(p) != (4, 4) for p in self.P):
            raise ValueError("P: every covariance is 4×4")
        return self


_ROWS = ("cls", "state", "x", "P", "hist", "misses", "age", "last_seen", "still_since", "anchor", "anchor_var",
         "conf", "boxes")  # fmt: skip
_ROW_TYPES: dict[str, tuple[type, tuple[int, ...]]] = {
    "cls": (np.intp, ()), "state": (np.int8, ()), "hist": (np.int64, ()), "misses": (np.int64, ()),
    "age": (np.int64, ()), "x": (float, (4,)), "P": (float, (4, 4)), "anchor": (float, (2,)), "boxes": (float, (4,)),
}  # fmt: skip
"""Each row's dtype and per-track shape, where it is not a float per track (for :meth:`Tracker.restore`)."""


@dataclass(frozen=True)
class TrackTable:
    """The tracks after a step, as parallel arrays (row k is one track); what the scene graph and contract read."""

    ids: list[str]
    classes: list[str]
    state: NDArray[np.int8]
    x: FloatArray  # T×4: north, east, v_north, v_east
    P: FloatArray  # T×4×4
    age_frames: NDArray[np.int64]
    stationary_s: FloatArray
    conf: FloatArray
    last_seen: FloatArray
    detected: NDArray[np.bool_]  # detected in this frame
    boxes: FloatArray  # T×4: the last matched pixel box
    detection_index: NDArray[np.intp]  # row in this frame's detection list, -1 if not detected now
    recent_hits: NDArray[np.int64]  # detections in the last 8 frames

    def __len__(self) -> int:
        return len(self.ids)

    def state_names(self) -> list[str]:
        return [STATE_NAMES[s] for s in self.state]


class Tracker:
    """Tracks of every class on the ground plane, kept across frames (see the module docs for the life cycle)."""

    def __init__(self, config: TrackerConfig | None = None) -> None:
        self.config = config or TrackerConfig()
        self.time_s: float | None = None
        self._class_index: dict[str, int] = {}
        self._counters: dict[str, int] = {}
        self._ids: list[str] = []
        self._cls = np.empty(0, np.intp)
        self._state = np.empty(0, np.int8)
        self._x = np.empty((0, 4))
        self._P = np.empty((0, 4, 4))
        self._hist = np.empty(0, np.int64)  # bit 0: detected in the latest frame
        self._misses = np.empty(0, np.int64)
        self._age = np.empty(0, np.int64)
        self._last_seen = np.empty(0)
        self._still_since = np.empty(0)
        self._anchor = np.empty((0, 2))
        self._anchor_var = np.empty(0)
        self._conf = np.empty(0)
        self._boxes = np.empty((0, 4))
        self._det_index = np.empty(0, np.intp)

    def __len__(self) -> int:
        return len(self._ids)

    def _class_of(self, name: str) -> int:
        return self._class_index.setdefault(name, len(self._class_index))

    def _new_id(self, class_name: str) -> str:
        prefix = _PREFIX.get(class_name, class_name[:1].upper() or "X")
        self._counters[prefix] = self._counters.get(prefix, 0) + 1
        return f"{prefix}-{self._counters[prefix]:02d}"

    def step(self, time_s: float, m: Measurements, view: FloatArray | None = None) -> TrackTable:
        """Advance to ``time_s`` and take in this frame's measurements; returns every live track.

        ``view``: the camera's ground footprint (K×2 corners), if known. A confirmed track without a detection
        whose prediction lies outside it is lost at once: it is out of sight, not missed.
        """
        cfg = self.config
        dt = 0.0 if self.time_s is None else max(0.0, time_s - self.time_s)
        self.time_s = time_s
        still = self._resting()
        x0, P0 = self._x[still], self._P[still]
        self._x, self._P = kalman.predict(self._x, self._P, dt, cfg.q)
        self._x[still], self._P[still] = x0, P0  # a motionless person out of sight stays where they were
        self._hist = (self._hist << 1) & 0xFF
        self._age += 1
        self._det_index = np.full(len(self._ids), -1, np.intp)

        for name in dict.fromkeys(m.classes):  # the frame's few class names; a new one is numbered on first sight
            self._class_of(name)
        det_cls = np.array([self._class_index[c] for c in m.classes], dtype=np.intp)
        a = associate(
            self._x[:, :2], self._P[:, :2, :2], self._cls, m.z, m.R, det_cls, gate=cfg.gate, max_radius_m=cfg.max_gate_m
        )
        t, d = a.tracks, a.detections
        self._x[t], self._P[t] = kalman.update(self._x[t], self._P[t], m.z[d], m.R[d])
        self._hist[t] |= 1
        self._misses[t] = 0
        self._misses[a.missed_tracks] += 1
        if view is not None and len(a.missed_tracks):
            gone = a.missed_tracks[~points_in_polygon(self._x[a.missed_tracks, :2], view)]
            self._misses[gone] = np.maximum(self._misses[gone], cfg.lost_after_misses)
        self._last_seen[t] = time_s
        self._conf[t] += cfg.conf_smoothing * (m.conf[d] - self._conf[t])
        self._boxes[t] = m.boxes[d]
        self._det_index[t] = m.index[d]
        self._state[t[self._state[t] == LOST]] = CONFIRMED  # found again: same id
        self._stillness(t, time_s)
        self._birth(a.new_detections, m, det_cls, time_s)
        self._life_cycle(time_s)
        return self.table()

    def _stillness(self, rows: IntArray, time_s: float) -> None:
        """Reset the stillness clock of the updated tracks that are clearly moving (see the module docs)."""
        cfg = self.config
        k = cfg.moving_sigmas
        speed, sigma = kalman.speed_and_sigma(self._x[rows], self._P[rows])
        drift = np.hypot(*(self._x[rows, :2] - self._anchor[rows]).T)
        pos_var = (self._P[rows, 0, 0] + self._P[rows, 1, 1]) / 2.0
        drift_sigma = np.sqrt(pos_var + self._anchor_var[rows])
        elapsed = time_s - self._still_since[rows]
        moving = (
            (speed - k * sigma > cfg.still_speed_mps)  # clearly moving now
            | (drift - k * drift_sigma > cfg.still_speed_mps * elapsed)  # clearly moved since stillness began
            | (drift > cfg.still_radius_m)  # crept too far
        )
        reset = rows[moving]
        self._still_since[reset] = time_s
        self._anchor[reset] = self._x[reset, :2]
        self._anchor_var[reset] = pos_var[moving]

    def _birth(self, new: IntArray, m: Measurements, det_cls: IntArray, time_s: float) -> None:
        if len(new) == 0:
            return
        x, P = kalman.initial_state(m.z[new], m.R[new], self.config.birth_speed_sigma)
        self._ids += [self._new_id(m.classes[j]) for j in new]
        n = len(new)
        self._cls = np.concatenate([self._cls, det_cls[new]])
        self._state = np.concatenate([self._state, np.full(n, TENTATIVE, np.int8)])
        self._x = np.concatenate([self._x, x])
        self._P = np.concatenate([self._P, P])
        self._hist = np.concatenate([self._hist, np.ones(n, np.int64)])
        self._misses = np.concatenate([self._misses, np.zeros(n, np.int64)])
        self._age = np.concatenate([self._age, np.ones(n, np.int64)])
        self._last_seen = np.concatenate([self._last_seen, np.full(n, time_s)])
        self._still_since = np.concatenate([self._still_since, np.full(n, time_s)])
        self._anchor = np.concatenate([self._anchor, m.z[new]])
        self._anchor_var = np.concatenate([self._anchor_var, (m.R[new, 0, 0] + m.R[new, 1, 1]) / 2.0])
        self._conf = np.concatenate([self._conf, m.conf[new]])
        self._boxes = np.concatenate([self._boxes, m.boxes[new]])
        self._det_index = np.concatenate([self._det_index, m.index[new]])

    def _resting(self) -> NDArray[np.bool_]:
        """Lost tracks that had been seen motionless long enough to be kept where they were (see the module docs)."""
        still = self._last_seen - self._still_since >= self.config.dormant_after_still_s
        return np.asarray((self._state == LOST) & still, dtype=np.bool_)

    def _dormant(self) -> NDArray[np.bool_]:
        """Resting tracks past the re-identification window: kept, but listed nowhere."""
        if self.time_s is None:
            return np.zeros(len(self._ids), bool)
        return np.asarray(self._resting() & (self.time_s - self._last_seen > self.config.reid_window_s), dtype=np.bool_)

    def _life_cycle(self, time_s: float) -> None:
        cfg = self.config
        window = (1 << cfg.confirm_window) - 1
        hits = _POPCOUNT[self._hist & window]
        tentative = self._state == TENTATIVE
        self._state[tentative & (hits >= cfg.confirm_hits)] = CONFIRMED
        self._state[(self._state == CONFIRMED) & (self._misses >= cfg.lost_after_misses)] = LOST
        hopeless = (self._state == TENTATIVE) & (
            (self._misses > cfg.confirm_window - cfg.confirm_hits) | (self._age >= cfg.confirm_window)
        )
        keep_for = np.where(self._resting(), cfg.dormant_window_s, cfg.reid_window_s)
        expired = (self._state == LOST) & (time_s - self._last_seen > keep_for)
        keep = ~(hopeless | expired)
        if keep.all():
            return
        rows = np.flatnonzero(keep)
        self._ids = [self._ids[i] for i in rows]
        for name in ("_cls", "_state", "_x", "_P", "_hist", "_misses", "_age", "_last_seen", "_still_since"):
            setattr(self, name, getattr(self, name)[rows])
        for name in ("_anchor", "_anchor_var", "_conf", "_boxes", "_det_index"):
            setattr(self, name, getattr(self, name)[rows])

    def state(self) -> TrackerState:
        """Every track and id counter now, to be restored later with :meth:`restore` (call it from the thread that
        steps the tracker, or under the lock that thread holds)."""
        rows = {name: getattr(self, f"_{name}").tolist() for name in _ROWS}
        return TrackerState(
            time_s=self.time_s, classes=list(self._class_index), counters=dict(self._counters), ids=list(self._ids),
            **rows,
        )  # fmt: skip

    def restore(self, state: TrackerState) -> None:
        """Take up the tracks and id counters of :meth:`state` (a resumed run): the same people keep their ids,
        stillness clocks and re-identification windows, and new tracks are numbered after the old ones."""
        self.time_s = state.time_s
        self._class_index = {name: k for k, name in enumerate(state.classes)}
        self._counters = dict(state.counters)
        self._ids = list(state.ids)
        n = len(state.ids)
        for name in _ROWS:
            dtype, shape = _ROW_TYPES.get(name, (float, ()))
            setattr(self, f"_{name}", np.array(getattr(state, name), dtype).reshape(n, *shape))
        self._det_index = np.full(n, -1, np.intp)

    def table(self) -> TrackTable:
        """The live tracks as arrays (copies: safe to keep); dormant ones are not listed."""
        names = list(self._class_index)
        rows = np.flatnonzero(~self._dormant())
        return TrackTable(
            ids=[self._ids[k] for k in rows],
            classes=[names[c] for c in self._cls[rows]],
            state=self._state[rows],
            x=self._x[rows],
            P=self._P[rows],
            age_frames=self._age[rows],
            stationary_s=np.maximum(self._last_seen[rows] - self._still_since[rows], 0.0),
            conf=np.clip(self._conf[rows], 0.0, 1.0),
            last_seen=self._last_seen[rows],
            detected=self._det_index[rows] >= 0,
            boxes=self._boxes[rows],
            detection_index=self._det_index[rows],
            recent_hits=_POPCOUNT[self._hist[rows]],
        )
