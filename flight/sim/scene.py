"""A scene in motion: every actor's position and velocity as numpy arrays, advanced deterministically from the seed.

:class:`SceneState` fills the scene's crowd zones (round(density × area) persons each, uniformly, behaviours drawn
from the zone's mix) after its explicit actors, then moves everyone in steps of ``dt``:

* **walkers** in a flowing zone head along the flow with a personal offset (an Ornstein–Uhlenbeck process, 14° std,
  4 s correlation time) at a personal speed (the flow's × U(0.8, 1.2)); **runners** go 2.5× faster. Crossing a
  side edge cancels the sideways part of the step and turns them back in; crossing the downstream edge, they leave
  and a new pilgrim (a new id, ``P-<n>``) enters at the upstream edge on the same line, so the density holds.
  In a milling zone (flow speed 0) walkers wander (heading random walk, 0.6 rad/√s) at 0.3–0.7 m/s and turn back
  at the edge. Walkers without a zone keep their velocity with a small heading jitter.
* **standing** people sway about their spot (3 cm std, 1.5 s correlation), **sitting** and **resting** ones less
  (1.5 and 1 cm); **collapsed** people and **parked** vehicles do not move at all; **driving** vehicles keep their
  velocity (or their zone's flow).

Crowd persons get ids ``P-1``, ``P-2``, … skipping the explicit actors' ids. Two states built from equal scenes and
stepped with equal ``dt`` sequences are identical. Positions are north/east metres from home; the ground is the
plane ``down = 0``.

>>> from flight.sim.scene_file import load_scene
>>> state = SceneState(load_scene("scenes/hajj_emergency.yaml"))
>>> before = state.positions.copy()
>>> state.advance_to(2.0)
>>> casualty = state.index_of("P-12")
>>> bool((state.positions[casualty] == before[casualty]).all()), state.time_s
(True, 2.0)
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from agentic_core.contracts.camera import CameraPose, CameraSpec
from agentic_core.contracts.pinhole import footprint
from flight.sim.scene_model import BEHAVIOURS, NE, Actor, BodySize, Scene, Zone, default_size

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

WALK_SPEED_RANGE = (0.8, 1.2)
"""A flowing zone's walkers go at the flow's speed times a personal factor drawn uniformly from this range."""
RUN_FACTOR = 2.5
MILL_SPEED_RANGE = (0.3, 0.7)
HEADING_STD_RAD = math.radians(14.0)
HEADING_TAU_S = 4.0
FREE_HEADING_STD_RAD = math.radians(8.0)
MILL_HEADING_RATE = 0.6
"""Heading random walk of milling walkers, rad/√s."""
SWAY_STD_M = {"standing": 0.03, "sitting": 0.015, "resting": 0.01}
SWAY_TAU_S = 1.5
CLEARANCE_MARGIN = 1e-9
"""A walker is known to be still inside without a test while it has moved less than its clearance less this share:
far above the rounding of a squared distance, far below any step."""
_StepConstants = tuple[FloatArray, FloatArray, float, FloatArray]
SIZE_SCALE_RANGE = (0.9, 1.1)
"""Crowd persons' bodies are the default box scaled by a factor drawn uniformly from this range."""

_CODE = {name: i for i, name in enumerate(BEHAVIOURS)}
_WALK, _RUN, _DRIVE = _CODE["walking"], _CODE["running"], _CODE["driving"]


class SceneState:
    """Where everyone in a :class:`Scene` is at ``time_s``; one caller steps it (not thread-safe).

    Arrays (N actors, explicit ones first in file order, then each zone's crowd): ``positions`` and
    ``velocities`` (N×2 north/east), ``headings`` (rad, body orientation), ``sizes`` (N×3 length, width, height
    m), ``behaviour_codes`` (into :data:`~flight.sim.scene_model.BEHAVIOURS`), ``class_codes`` (into
    ``class_names``), ``zone_index`` (into ``scene.zones``, -1 for none) and ``generations`` (+1 each time a slot is
    taken over by a new pilgrim); ``ids`` is the matching list of actor ids.
    """

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        self.time_s = 0.0
        explicit = scene.actors
        crowd_rng = np.random.default_rng([scene.seed, 0])
        self._rng = np.random.default_rng([scene.seed, 1])
        self.class_names: list[str] = sorted({"person", *(a.class_name for a in explicit)})
        parts = [_explicit_arrays(explicit, self.class_names, scene)]
        taken = {a.id for a in explicit}
        self._next_number = 1
        ids = [a.id for a in explicit]
        for zi, zone in enumerate(scene.zones):
            n = zone.persons
            if n == 0:
                continue
            parts.append(_crowd_arrays(zone, zi, n, crowd_rng, self.class_names.index("person")))
            for _ in range(n):
                ids.append(self._new_id(taken))
        self._taken = taken
        self.ids: list[str] = ids
        cat = {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}
        self.positions: FloatArray = cat["pos"]
        self.headings: FloatArray = cat["heading"]
        self.sizes: FloatArray = cat["size"]
        self.behaviour_codes: IntArray = cat["behaviour"].astype(np.int64)
        self.class_codes: IntArray = cat["cls"].astype(np.int64)
        self.zone_index: IntArray = cat["zone"].astype(np.int64)
        self._speed: FloatArray = cat["speed"]
        self._base: FloatArray = cat["base"]  # heading the offset is measured from (rad)
        self.generations: IntArray = np.zeros(len(ids), dtype=np.int64)
        n_all = len(ids)
        self._anchor = self.positions.copy()
        self._sway = np.zeros((n_all, 2))
        codes = self.behaviour_codes
        self._sway_std = np.zeros(n_all)
        for name, std in SWAY_STD_M.items():
            self._sway_std[codes == _CODE[name]] = std
        moving = np.isin(codes, [_WALK, _RUN, _DRIVE])
        flows = np.array([z.flow.speed_mps > 0 for z in scene.zones] + [False], dtype=bool)
        zoned = moving & (self.zone_index >= 0)
        flowing = zoned & flows[self.zone_index]
        walking = codes != _DRIVE
        self._moving = moving
        self._mill = zoned & ~flows[self.zone_index]
        self._heading_std = np.zeros(n_all)  # Ornstein–Uhlenbeck std of the heading offset; 0: none
        self._heading_std[flowing & walking] = HEADING_STD_RAD
        self._heading_std[moving & (self.zone_index < 0) & walking] = FREE_HEADING_STD_RAD
        self._sway_rows = np.flatnonzero(~moving & (self._sway_std > 0))
        self._moving_rows = np.flatnonzero(moving)
        self._constants_by_dt: dict[float, _StepConstants] = {}
        self._zone_rows = [np.flatnonzero(zoned & (self.zone_index == zi)) for zi in range(len(scene.zones))]
        self._offset = self._rng.standard_normal(n_all) * self._heading_std
        self._clear_at = np.full((n_all, 2), np.nan)  # where each zoned walker's clearance was last measured
        self._clear_sq = np.zeros(n_all)  # the squared clearance there, a hair short (CLEARANCE_MARGIN)
        self._speed[~moving] = 0.0
        self.velocities: FloatArray = self._model_velocity()
        self._index = {ident: i for i, ident in enumerate(ids)}

    def __len__(self) -> int:
        return len(self.ids)

    @property
    def behaviours(self) -> list[str]:
        return [BEHAVIOURS[c] for c in self.behaviour_codes]

    @property
    def person_mask(self) -> BoolArray:
        mask: BoolArray = self.class_codes == self.class_names.index("person")
        return mask

    def index_of(self, actor_id: str) -> int:
        """The array row of an actor; ``KeyError`` for an id not (or no longer) in the scene: a pilgrim who left a
        flowing zone downstream is gone, and the one who entered upstream in that row has a new id."""
        return self._index[actor_id]

    def step(self, dt: float) -> None:
        """Advance every actor by ``dt`` seconds."""
        if dt <= 0.0:
            raise ValueError(f"dt must be positive, got {dt}")
        rng = self._rng
        decay, scale, sway_decay, sway_scale = self._constants(dt)
        self._offset = decay * self._offset + scale * rng.standard_normal(len(self.ids))
        velocity = self._model_velocity()
        old = self.positions
        new = old + velocity * dt  # zero for those who do not walk, so they stay exactly where they are
        entered: list[int] = []
        # who has moved less than their clearance, for every row at once (contiguous arrays, no gathers): a zone's
        # turn below changes only its own rows, so this holds for the zones after it too. Squared, with a margin
        # far above rounding, so a row is only ever sure when the exact distance says so too.
        gap = new - self._clear_at
        gap *= gap
        sure = gap[:, 0] + gap[:, 1] < self._clear_sq  # never measured: NaN, so tested
        for zone, rows in zip(self.scene.zones, self._zone_rows, strict=True):
            if len(rows):
                out = self._stepped_out(zone, rows[~sure[rows]], new)
                if len(out):
                    entered += self._keep_inside(zone, out, old, new, velocity, dt)
        noise = rng.standard_normal((len(self.ids), 2))
        noise *= sway_scale
        self._sway *= sway_decay
        self._sway += noise
        swaying = self._sway_rows
        new[swaying] = self._anchor[swaying] + self._sway[swaying]
        self.velocities = (new - old) / dt
        self.velocities[entered] = velocity[entered]  # new pilgrims: their walking velocity, not the jump
        self.positions = new
        moving = self._moving_rows
        self.headings = self.headings.copy()
        self.headings[moving] = np.arctan2(self.velocities[moving, 1], self.velocities[moving, 0])
        self.time_s += dt

    def _constants(self, dt: float) -> _StepConstants:
        """The per-row factors of a step of ``dt`` (heading decay and noise scale, sway decay and noise scale),
        worked out once for each ``dt`` among the last few: a flight steps by 1/30 s thousands of times, with a
        shorter step up to each frame's time between."""
        known = self._constants_by_dt.pop(dt, None)
        if known is not None:
            self._constants_by_dt[dt] = known  # the most recently used last
            return known
        a = math.exp(-dt / HEADING_TAU_S)
        decay = np.where(self._heading_std > 0, a, 1.0)
        scale = math.sqrt(1.0 - a * a) * self._heading_std + np.where(self._mill, MILL_HEADING_RATE * math.sqrt(dt), 0)
        sa = math.exp(-dt / SWAY_TAU_S)
        sway_scale = (math.sqrt(1.0 - sa * sa) * self._sway_std)[:, None]
        if len(self._constants_by_dt) >= 4:
            del self._constants_by_dt[next(iter(self._constants_by_dt))]  # the least recently used
        self._constants_by_dt[dt] = (decay, scale, sa, sway_scale)
        return decay, scale, sa, sway_scale

    def advance_to(self, time_s: float, max_dt: float = 1.0 / 30.0) -> None:
        """Step until ``time_s`` in steps of at most ``max_dt``; a time already passed changes nothing."""
        while self.time_s < time_s - 1e-9:
            self.step(min(max_dt, time_s - self.time_s))
        if abs(self.time_s - time_s) <= 1e-9:
            self.time_s = time_s

    def in_sight(self, spec: CameraSpec, pose: CameraPose) -> IntArray:
        """Rows near a camera's ground footprint, with a margin for the tallest body (all rows when the camera sees
        the horizon): what a camera may see, for the detector and the renderer to look at closer."""
        corners = footprint(spec, pose)
        if corners is None:
            return np.arange(len(self), dtype=np.int64)
        margin = 5.0 + float(self.sizes[:, 2].max(initial=0.0))
        lo, hi = corners.min(axis=0) - margin, corners.max(axis=0) + margin
        pos = self.positions
        near = (pos[:, 0] >= lo[0]) & (pos[:, 0] <= hi[0]) & (pos[:, 1] >= lo[1]) & (pos[:, 1] <= hi[1])
        return np.flatnonzero(near).astype(np.int64)

    def corners(self, rows: IntArray | None = None) -> FloatArray:
        """The 8 corners (M×8×3 north/east/down, the ground at down 0) of the body boxes of ``rows`` (all): the
        ground face's four in order around it, then the top face's above them."""
        idx = np.arange(len(self.ids)) if rows is None else np.asarray(rows)
        h = self.headings[idx]
        fwd = np.column_stack([np.cos(h), np.sin(h)])
        side = np.column_stack([-np.sin(h), np.cos(h)])
        half_l = (self.sizes[idx, 0] / 2.0)[:, None]
        half_w = (self.sizes[idx, 1] / 2.0)[:, None]
        out = np.zeros((len(idx), 8, 3))
        for k, (sl, sw) in enumerate(((-1.0, -1.0), (-1.0, 1.0), (1.0, 1.0), (1.0, -1.0))):  # around the face
            ground = self.positions[idx] + sl * half_l * fwd + sw * half_w * side
            out[:, k, :2] = ground
            out[:, k + 4, :2] = ground
            out[:, k + 4, 2] = -self.sizes[idx, 2]
        return out

    def actor(self, actor_id: str) -> Actor:
        """One actor as it is now (a pydantic snapshot)."""
        i = self.index_of(actor_id)
        zi = int(self.zone_index[i])
        length, width, height = (float(v) for v in self.sizes[i])
        return Actor(
            id=self.ids[i],
            class_name=self.class_names[self.class_codes[i]],
            position=NE(north=float(self.positions[i, 0]), east=float(self.positions[i, 1])),
            velocity=NE(north=float(self.velocities[i, 0]), east=float(self.velocities[i, 1])),
            behaviour=BEHAVIOURS[self.behaviour_codes[i]],
            heading_deg=math.degrees(float(self.headings[i])),
            size=BodySize(length_m=length, width_m=width, height_m=height),
            zone=self.scene.zones[zi].id if zi >= 0 else None,
        )

    def _model_velocity(self) -> FloatArray:
        """Where the moving actors head and how fast (N×2; zero for the others)."""
        heading = self._base + self._offset
        v: FloatArray = np.empty((len(heading), 2))
        v[:, 0] = np.cos(heading)
        v[:, 1] = np.sin(heading)
        v *= self._speed[:, None]
        return v

    def _stepped_out(self, zone: Zone, test: IntArray, new: FloatArray) -> IntArray:
        """The rows of ``test`` (``zone``'s walkers) whose new position is outside it. :meth:`step` hands over only
        those that have moved at least their clearance (distance to the boundary, measured when last found inside)
        from where it was measured: nearer than that to an inside point, a point is inside too. Exactly
        ``zone.contains``, cheaper."""
        if len(test) == 0:
            return test
        inside, clearance = zone.inside_and_clearance(new[test])
        kept = test[inside]
        self._clear_at[kept] = new[kept]
        self._clear_sq[kept] = np.square(clearance[inside]) * (1.0 - CLEARANCE_MARGIN)
        out: IntArray = test[~inside]
        return out

    def _keep_inside(
        self, zone: Zone, rows: IntArray, old: FloatArray, new: FloatArray, velocity: FloatArray, dt: float
    ) -> list[int]:
        """Walkers of ``rows`` stepped out of ``zone``: turn them back, or let them leave downstream and re-enter
        (their rows are returned)."""
        if zone.flow.speed_mps <= 0.0:  # milling: stay put this step and turn around
            new[rows] = old[rows]
            self._offset[rows] += math.pi
            return []
        f = zone.flow.direction
        move = velocity[rows] * dt
        along = (move @ f)[:, None] * f
        sideways_ok = zone.contains(old[rows] + (move - along))
        side = rows[~sideways_ok]
        new[side] = old[side] + along[~sideways_ok]
        self._offset[side] = -self._offset[side]  # steer back in
        still_out = side[~zone.contains(new[side])] if len(side) else side
        new[still_out] = old[still_out]
        ahead = rows[sideways_ok]
        leaving = (velocity[ahead] @ f) > 0.0
        downstream = ahead[leaving]
        for i in downstream:
            new[i] = _upstream_entry(zone, new[i], f)
            del self._index[self.ids[i]]  # that pilgrim has gone
            self.ids[i] = self._new_id(self._taken)
            self._index[self.ids[i]] = int(i)
            self.generations[i] += 1
            self._offset[i] = self._rng.normal(0.0, HEADING_STD_RAD)
        upstream = ahead[~leaving]
        new[upstream] = old[upstream]
        return [int(i) for i in downstream]

    def _new_id(self, taken: set[str]) -> str:
        while f"P-{self._next_number}" in taken:
            self._next_number += 1
        ident = f"P-{self._next_number}"
        taken.add(ident)
        self._next_number += 1
        return ident


def _explicit_arrays(actors: list[Actor], class_names: list[str], scene: Scene) -> dict[str, FloatArray]:
    zones = {z.id: i for i, z in enumerate(scene.zones)}
    n = len(actors)
    out = {key: np.zeros(n) for key in ("heading", "behaviour", "cls", "zone", "speed", "base")}
    out["pos"] = np.zeros((n, 2))
    out["size"] = np.zeros((n, 3))
    for i, a in enumerate(actors):
        size = a.body_size()
        zi = zones.get(a.zone, -1) if a.zone is not None else -1
        speed = math.hypot(a.velocity.north, a.velocity.east)
        heading = math.atan2(a.velocity.east, a.velocity.north) if speed > 0 else math.radians(a.heading_deg)
        zone = scene.zones[zi] if zi >= 0 else None
        base = heading
        if zone is not None and not speed and a.behaviour in ("walking", "running"):
            speed = zone.flow.speed_mps if zone.flow.speed_mps > 0 else sum(MILL_SPEED_RANGE) / 2.0
            speed *= RUN_FACTOR if a.behaviour == "running" else 1.0
        if zone is not None and zone.flow.speed_mps > 0:
            base = math.radians(zone.flow.heading_deg)
        out["pos"][i] = (a.position.north, a.position.east)
        out["size"][i] = (size.length_m, size.width_m, size.height_m)
        out["heading"][i] = heading
        out["behaviour"][i] = _CODE[a.behaviour]
        out["cls"][i] = class_names.index(a.class_name)
        out["zone"][i] = zi
        out["speed"][i] = speed
        out["base"][i] = base
    return out


def _crowd_arrays(zone: Zone, zi: int, n: int, rng: np.random.Generator, person: int) -> dict[str, FloatArray]:
    names = list(zone.mix)
    shares = np.array([zone.mix[k] for k in names], dtype=float)
    picks = rng.choice(len(names), size=n, p=shares / shares.sum())
    codes = np.array([_CODE[names[k]] for k in picks])
    sizes = np.array([_size_tuple(default_size("person", names[k])) for k in range(len(names))])[picks]
    sizes = sizes * rng.uniform(*SIZE_SCALE_RANGE, size=n)[:, None]
    heading = rng.uniform(-math.pi, math.pi, n)
    flowing = zone.flow.speed_mps > 0
    if flowing:
        speed = zone.flow.speed_mps * rng.uniform(*WALK_SPEED_RANGE, n)
        base = np.full(n, math.radians(zone.flow.heading_deg))
    else:
        speed = rng.uniform(*MILL_SPEED_RANGE, n)
        base = heading.copy()
    speed = np.where(codes == _RUN, speed * RUN_FACTOR, speed)
    speed = np.where(np.isin(codes, [_WALK, _RUN]), speed, 0.0)
    return {
        "pos": zone.sample(n, rng),
        "heading": np.where(np.isin(codes, [_WALK, _RUN]) & flowing, base, heading),
        "size": sizes,
        "behaviour": codes.astype(float),
        "cls": np.full(n, float(person)),
        "zone": np.full(n, float(zi)),
        "speed": speed,
        "base": base,
    }


def _size_tuple(size: BodySize | None) -> tuple[float, float, float]:
    assert size is not None
    return size.length_m, size.width_m, size.height_m


def _upstream_entry(zone: Zone, point: FloatArray, flow: FloatArray) -> FloatArray:
    """Where the line through ``point`` along the flow enters the zone upstream (a little inside it)."""
    back = -flow
    if zone.circle is not None and zone.polygon is None:
        c = zone.circle.center.array()
        rel = point - c
        along = float(rel @ back)  # |rel + t·back| = r, the far root
        disc = along**2 - (float(rel @ rel) - zone.circle.radius_m**2)
        t = -along + math.sqrt(max(disc, 0.0))
    else:
        v = zone.vertices()
        w = np.roll(v, -1, axis=0) - v
        cross = back[0] * w[:, 1] - back[1] * w[:, 0]
        ok = np.abs(cross) > 1e-12
        rel = v - point
        with np.errstate(divide="ignore", invalid="ignore"):
            t_all = (rel[:, 0] * w[:, 1] - rel[:, 1] * w[:, 0]) / cross
            s_all = (rel[:, 0] * back[1] - rel[:, 1] * back[0]) / cross
        hits = ok & (s_all >= 0.0) & (s_all <= 1.0) & (t_all > 0.0)
        t = float(t_all[hits].max()) if hits.any() else 0.0
    entry: FloatArray = point + back * max(t - 0.05, 0.0)
    return entry
