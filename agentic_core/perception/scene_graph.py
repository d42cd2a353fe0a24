"""The 3D semantic scene graph: the aircraft, the tracks and the landmarks as nodes, their relations as edges.

Relations are recomputed from the tracks every update (numpy and a KD-tree, so a thousand people stay cheap);
the networkx graph (:attr:`SceneGraph.graph`, a ``MultiDiGraph``, brought up to date when read) keeps its nodes
across updates and has its edges replaced: an edge per binary relation (keyed by the predicate, ``value`` as
attribute), ``ego -observes-> track`` for the tracks detected in this frame, and unary relations as node
attributes (``stationary``). Definitions (thresholds in :class:`RelationConfig`); subjects are confirmed tracks:

* ``near`` — to each landmark whose point or area edge is within ``near_landmark_m`` (value: distance, m), and to
  the nearest other confirmed track within ``near_m`` (value: distance, m; the relation is symmetric, so two
  tracks each other's nearest are related once).
* ``isolated_from`` ``crowd`` — a person whose nearest other person (any live track: confirmed, lost a moment
  ago, or tentative with two detections already — not a one-frame false positive) is farther than
  ``isolation_m`` (10 m: the scenes' ground truth calls a casualty isolated beyond 15 m; a Hajj crowd's people
  are 0.5–2 m apart), *and* with fewer than ``max_density`` persons/m² within ``density_radius_m`` (a person just
  outside a dense crowd is beside it, not isolated). Judged only for persons at least ``view_margin_m`` (3 m)
  inside the camera's footprint (a track coasting out of sight is never judged): whoever comes into view first
  has the rest of their group still out of sight, and would look alone until the others are tracked (the
  normal Hajj scene's four people in the shade, 1.5–2 m apart, did exactly that without the margin). The margin
  costs a newcomer ``view_margin_m`` / ground speed before it can be judged (0.6 s at 5 m/s); people who just
  left the view still count, as lost tracks. Value: distance to the nearest other person (m), or none when
  nobody else is tracked.
* ``inside`` — a landmark with an area (polygon, or a point with ``radius_m``) contains the track.
* ``moving_toward`` — the track is clearly moving (speed above ``moving_min_speed_mps``) with its velocity within
  ``toward_angle_deg`` of the bearing to a landmark no farther than ``toward_max_m`` (and not inside it).
  Value: distance, m.
* ``stationary`` — observed motionless (:mod:`.tracker`: ``stationary_s``) for at least ``stationary_min_s``, and
  its filtered speed within one standard deviation of ``stationary_max_speed_mps`` or less. Value:
  ``stationary_s``.

Landmarks are anything with an ``id``, a ``kind`` and a position (``north``/``east``, ``north_m``/``east_m``, or a
``position`` record with them), optionally a ``polygon`` (points or ``[north, east]`` pairs), ``radius_m`` or a
``circle`` (``center``, ``radius_m``): the scene's landmarks and crowd zones both fit. :func:`as_landmark` reads them.

>>> from agentic_core.perception.tracker import TrackTable
>>> x = np.array([[0.0, 0.0, 0, 0], [30.0, 0.0, 0, 0], [30.8, 0.3, 0, 0], [31.0, -0.5, 0, 0]])
>>> table = TrackTable(ids=["P-01", "P-02", "P-03", "P-04"], classes=["person"] * 4, state=np.ones(4, np.int8),
...     x=x, P=np.array([np.eye(4) * 1e-3] * 4), age_frames=np.full(4, 60), stationary_s=np.array([5.0, 0, 0, 0]),
...     conf=np.full(4, 0.9), last_seen=np.zeros(4), detected=np.ones(4, bool), boxes=np.zeros((4, 4)),
...     detection_index=np.arange(4), recent_hits=np.full(4, 8))
>>> graph = SceneGraph()
>>> rel = graph.update(table, landmarks=[as_landmark({"id": "Exit-3", "kind": "exit", "north": 2, "east": 1})])
>>> sorted((r.subj, r.pred, r.obj) for r in rel if r.subj == "P-01")
[('P-01', 'isolated_from', 'crowd'), ('P-01', 'near', 'Exit-3'), ('P-01', 'stationary', None)]
>>> sorted(graph.graph.successors("P-01")), graph.graph.nodes["P-01"]["stationary"]
(['Exit-3', 'crowd'], 5.0)
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any, NamedTuple

import networkx as nx
import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict, Field
from scipy.spatial import cKDTree

from agentic_core.contracts.polygon import Ring

from .kalman import speed_and_sigma
from .tracker import CONFIRMED, TENTATIVE, TrackTable
from .world_model import Landmark

FloatArray = NDArray[np.float64]


class RelationConfig(BaseModel):
    """The thresholds behind each relation (see the module docs for the definitions)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    near_m: float = Field(default=2.0, gt=0, description="a track near its nearest other track")
    near_landmark_m: float = Field(default=10.0, gt=0, description="a track near a landmark")
    isolation_m: float = Field(default=10.0, gt=0, description="nearest other person farther than this")
    density_radius_m: float = Field(default=15.0, gt=0, description="local density measured within this radius")
    max_density: float = Field(default=0.05, ge=0, description="persons/m² under which the area counts as empty")
    view_margin_m: float = Field(default=3.0, ge=0, description="isolation judged this far inside the footprint")
    isolation_class: str = "person"
    toward_angle_deg: float = Field(default=30.0, gt=0, le=180)
    toward_max_m: float = Field(default=100.0, gt=0)
    moving_min_speed_mps: float = Field(default=0.5, gt=0)
    stationary_min_s: float = Field(default=0.15, ge=0, description="observed motionless at least this long")
    stationary_max_speed_mps: float = Field(default=0.3, gt=0, description="speed - 1 sigma under this")


class Rel(NamedTuple):
    """One relation as computed (the contract's :class:`~.world_model.Relation` is built from it)."""

    subj: str
    pred: str
    obj: str | None
    value: float | None


def _get(record: Any, *names: str) -> Any:
    for name in names:
        value = record.get(name) if isinstance(record, Mapping) else getattr(record, name, None)
        if value is not None:
            return value
    return None


def _point(record: Any) -> tuple[float, float] | None:
    if isinstance(record, Sequence) and not isinstance(record, str) and len(record) == 2:
        return float(record[0]), float(record[1])
    north, east = _get(record, "north", "north_m"), _get(record, "east", "east_m")
    return None if north is None or east is None else (float(north), float(east))


def as_landmark(record: Any) -> Landmark:
    """A landmark (or zone) record of any of the shapes in the module docs, as the contract's :class:`Landmark`."""
    if isinstance(record, Landmark):
        return record
    ident, kind = _get(record, "id"), _get(record, "kind") or "landmark"
    polygon = _get(record, "polygon")
    corners = [_point(p) for p in polygon] if polygon is not None else None
    circle = _get(record, "circle")
    radius = _get(record, "radius_m") or (_get(circle, "radius_m") if circle is not None else None)
    centre = _point(record) or _point(_get(record, "position", "center") or {})
    if centre is None and circle is not None:
        centre = _point(_get(circle, "center") or {})
    if centre is None and corners and all(c is not None for c in corners):
        centre = (sum(c[0] for c in corners if c) / len(corners), sum(c[1] for c in corners if c) / len(corners))
    if ident is None or centre is None or (corners is not None and any(c is None for c in corners)):
        raise ValueError(f"not a landmark (needs an id and a north/east position or polygon): {record!r}")
    return Landmark(
        id=str(ident),
        kind=str(kind),
        north=centre[0],
        east=centre[1],
        radius_m=None if radius is None else float(radius),
        polygon=None if corners is None else [[c[0], c[1]] for c in corners if c is not None],
    )


def _shape_key(lm: Landmark) -> tuple[Any, ...]:
    """What a landmark's geometry rests on, by value (so a landmark edited in place has another key)."""
    corners = None if lm.polygon is None else [tuple(corner) for corner in lm.polygon]
    return lm.north, lm.east, lm.radius_m, corners


class _Shape(NamedTuple):
    """A landmark's geometry, worked out once for as long as the landmark stays as it is (its :func:`_shape_key`):
    its polygon's :class:`~agentic_core.contracts.polygon.Ring` (``None`` for a point or circle) and its bounding
    box."""

    key: tuple[Any, ...]
    ring: Ring | None
    lo: FloatArray
    hi: FloatArray


def _shape(lm: Landmark, key: tuple[Any, ...]) -> _Shape:
    if lm.polygon is not None:
        ring = Ring(lm.polygon)
        lo, hi = ring.a.min(axis=0), ring.a.max(axis=0)
    else:
        ring = None
        centre, radius = np.array([lm.north, lm.east]), lm.radius_m or 0.0
        lo, hi = centre - radius, centre + radius
    return _Shape(key, ring, lo, hi)


def _landmark_geometry(
    lm: Landmark, shape: _Shape, points: FloatArray, reach: FloatArray
) -> tuple[FloatArray, NDArray[np.bool_]]:
    """Distance from points to a landmark (its point, or its area's edge; 0 inside) and which are inside. A point
    farther than its ``reach`` from the landmark's bounding box is neither, whatever its distance: it is given +inf
    without the polygon tests (most tracks are far from most landmarks)."""
    lo, hi = shape.lo, shape.hi
    close = np.flatnonzero(
        np.all(points >= lo - reach[:, None], axis=1) & np.all(points <= hi + reach[:, None], axis=1)
    )
    dist = np.full(len(points), np.inf)
    inside = np.zeros(len(points), dtype=bool)
    if len(close) == 0:
        return dist, inside
    pts = points[close]
    if shape.ring is not None:
        d = shape.ring.outside_by(pts)
        within = d == 0.0
    else:
        d = np.hypot(pts[:, 0] - lm.north, pts[:, 1] - lm.east)
        within = d <= lm.radius_m if lm.radius_m is not None else np.zeros(len(pts), dtype=bool)
        if lm.radius_m is not None:
            d = np.maximum(d - lm.radius_m, 0.0)
    dist[close], inside[close] = d, within
    return dist, inside


class SceneGraph:
    """Relations among the tracks and landmarks, and the networkx graph holding them (see the module docs)."""

    def __init__(self, config: RelationConfig | None = None) -> None:
        self.config = config or RelationConfig()
        self._graph: nx.MultiDiGraph = nx.MultiDiGraph()
        self._graph.add_node("ego", kind="ego")
        self._graph.add_node("crowd", kind="group")
        self._pending: tuple[TrackTable, list[Landmark], Mapping[str, Any]] | None = None
        self.relations: list[Rel] = []
        self._shapes: dict[str, _Shape] = {}  # the last update's landmarks' shapes, by id

    @property
    def graph(self) -> nx.MultiDiGraph:
        """The networkx graph as of the last update (brought up to date when read: an update itself only computes
        the relations, so frames nobody inspects the graph in cost nothing for it)."""
        if self._pending is not None:
            tracks, landmarks, ego = self._pending
            self._refresh_graph(tracks, landmarks, self.relations, ego)
            self._pending = None
        return self._graph

    def update(
        self,
        tracks: TrackTable,
        *,
        landmarks: Iterable[Landmark] = (),
        footprint: FloatArray | None = None,
        ego: Mapping[str, Any] | None = None,
    ) -> list[Rel]:
        """Recompute every relation from the tracks (``footprint``: the camera's ground corners, N×2, or ``None``
        if unknown: then isolation is judged everywhere) and refresh the graph."""
        landmarks = list(landmarks)
        rels: list[Rel] = []
        subj = np.flatnonzero(tracks.state == CONFIRMED)
        if len(subj):
            speed, sigma = speed_and_sigma(tracks.x[subj], tracks.P[subj])
            rels += self._stationary(tracks, subj, speed, sigma)
            rels += self._isolated(tracks, subj, footprint)
            rels += self._near_tracks(tracks, subj)
            rels += self._landmark_relations(tracks, subj, landmarks, speed, sigma)
        self.relations = rels
        self._pending = (tracks, landmarks, ego or {})
        return rels

    def _stationary(
        self, tracks: TrackTable, subj: NDArray[np.intp], speed: FloatArray, sigma: FloatArray
    ) -> list[Rel]:
        cfg = self.config
        still = (tracks.stationary_s[subj] >= cfg.stationary_min_s) & (speed - sigma < cfg.stationary_max_speed_mps)
        return [Rel(tracks.ids[i], "stationary", None, float(tracks.stationary_s[i])) for i in subj[still]]

    def _isolated(self, tracks: TrackTable, subj: NDArray[np.intp], footprint: FloatArray | None) -> list[Rel]:
        cfg = self.config
        persons = np.array([c == cfg.isolation_class for c in tracks.classes], dtype=bool)
        cand = subj[persons[subj]]
        if len(cand) == 0:
            return []
        # neighbours: every person track (lost a moment ago too) but one-frame wonders (false positives)
        crowd = np.flatnonzero(persons & ((tracks.state != TENTATIVE) | (tracks.recent_hits >= 2)))
        tree = cKDTree(tracks.x[crowd, :2])
        k = min(2, len(crowd))
        dist, _ = tree.query(tracks.x[cand, :2], k=k, distance_upper_bound=cfg.isolation_m + 1.0)
        nearest = dist[:, 1] if k == 2 else np.full(len(cand), np.inf)  # column 0 is the person themself
        lonely = nearest > cfg.isolation_m
        cand, nearest = cand[lonely], nearest[lonely]
        if footprint is not None and len(cand):
            ring = Ring(footprint)
            pts = tracks.x[cand, :2]
            seen = ring.contains(pts) & (ring.distance(pts) >= cfg.view_margin_m)
            cand, nearest = cand[seen], nearest[seen]
        if len(cand) == 0:
            return []
        counts = tree.query_ball_point(tracks.x[cand, :2], r=cfg.density_radius_m, return_length=True) - 1
        density = counts / (math.pi * cfg.density_radius_m**2)
        sparse = density < cfg.max_density
        if np.isinf(nearest).any():  # beyond the search bound: measure it
            far = np.isinf(nearest)
            d, _ = tree.query(tracks.x[cand[far], :2], k=k)
            nearest[far] = d[:, 1] if k == 2 else np.inf
        return [
            Rel(tracks.ids[i], "isolated_from", "crowd", None if math.isinf(d) else round(float(d), 2))
            for i, d in zip(cand[sparse], nearest[sparse], strict=True)
        ]

    def _near_tracks(self, tracks: TrackTable, subj: NDArray[np.intp]) -> list[Rel]:
        if len(subj) < 2:
            return []
        pts = tracks.x[subj, :2]
        dist, idx = cKDTree(pts).query(pts, k=2, distance_upper_bound=self.config.near_m)
        a = np.flatnonzero(np.isfinite(dist[:, 1]))
        b = idx[a, 1]
        once = (a < b) | (idx[b, 1] != a)  # a pair of mutual nearest: once
        a, b, d = a[once], b[once], np.round(dist[a[once], 1], 2).tolist()
        ids = tracks.ids
        return [Rel(ids[subj[i]], "near", ids[subj[j]], v) for i, j, v in zip(a.tolist(), b.tolist(), d, strict=True)]

    def _landmark_relations(
        self,
        tracks: TrackTable,
        subj: NDArray[np.intp],
        landmarks: list[Landmark],
        speed: FloatArray,
        sigma: FloatArray,
    ) -> list[Rel]:
        if not landmarks:
            return []
        cfg = self.config
        pts = tracks.x[subj, :2]
        vel = tracks.x[subj, 2:4]
        moving = speed - 2.0 * sigma > cfg.moving_min_speed_mps
        cos_limit = math.cos(math.radians(cfg.toward_angle_deg))
        reach = np.where(moving, max(cfg.near_landmark_m, cfg.toward_max_m), cfg.near_landmark_m)
        rels: list[Rel] = []
        shapes = self._shapes
        self._shapes = {}
        for lm in landmarks:
            key = _shape_key(lm)
            shape = shapes.get(lm.id)
            if shape is None or shape.key != key:
                shape = _shape(lm, key)
            self._shapes[lm.id] = shape
            dist, inside = _landmark_geometry(lm, shape, pts, reach)
            for a in np.flatnonzero(inside):
                rels.append(Rel(tracks.ids[subj[a]], "inside", lm.id, None))
            for a in np.flatnonzero(~inside & (dist <= cfg.near_landmark_m)):
                rels.append(Rel(tracks.ids[subj[a]], "near", lm.id, round(float(dist[a]), 2)))
            rows = np.flatnonzero(moving & ~inside & (dist <= cfg.toward_max_m))
            if len(rows):
                bearing = np.array([lm.north, lm.east]) - pts[rows]
                norm = np.maximum(np.hypot(bearing[:, 0], bearing[:, 1]) * speed[rows], 1e-9)
                cos = np.einsum("ij,ij->i", bearing, vel[rows]) / norm
                for a in rows[cos >= cos_limit]:
                    rels.append(Rel(tracks.ids[subj[a]], "moving_toward", lm.id, round(float(dist[a]), 2)))
        return rels

    def _refresh_graph(
        self, tracks: TrackTable, landmarks: list[Landmark], rels: list[Rel], ego: Mapping[str, Any]
    ) -> None:
        g = self._graph
        g.clear_edges()
        live = set(tracks.ids)
        landmark_ids = {lm.id for lm in landmarks}
        stale = [n for n, kind in g.nodes(data="kind") if kind in ("track", "landmark")]
        g.remove_nodes_from([n for n in stale if n not in live and n not in landmark_ids])
        g.nodes["ego"].update(ego)
        for lm in landmarks:
            g.add_node(lm.id, kind="landmark", landmark_kind=lm.kind, north=lm.north, east=lm.east)
        states = tracks.state_names()
        for k, ident in enumerate(tracks.ids):
            attrs: dict[str, Any] = {"kind": "track", "class": tracks.classes[k], "state": states[k]}
            attrs |= {"stationary": None, "north": float(tracks.x[k, 0]), "east": float(tracks.x[k, 1])}
            if ident in g:
                g.nodes[ident].update(attrs)
            else:
                g.add_node(ident, **attrs)
        g.add_edges_from((r.subj, r.obj, r.pred, {"value": r.value}) for r in rels if r.obj is not None)
        for r in rels:
            if r.obj is None:  # unary relations are node attributes: P-12 stationary=11.2
                g.nodes[r.subj][r.pred] = r.value
        g.add_edges_from(("ego", tracks.ids[k], "observes", {}) for k in np.flatnonzero(tracks.detected))
