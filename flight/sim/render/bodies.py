"""People and vehicles as the renderer draws them: each person a few capsules (body, legs, head) placed by pose
and heading in the world, each vehicle a box; their shadows on the ground; their looks drawn from the scene.

Poses: ``standing`` (standing and the scene's standing people), ``walking`` (walking, running: legs in stride),
``sitting`` (torso upright, legs forward) and ``lying`` (resting, collapsed: the whole body along the heading,
the head at the heading's end). Sizes scale with the actor's body box, so a taller pilgrim is drawn taller.

>>> from flight.sim.scene_file import load_scene
>>> from flight.sim.scene import SceneState
>>> state = SceneState(load_scene("scenes/hajj_emergency.yaml"))
>>> looks = Looks(state, seed=1)
>>> parts = person_parts(state, np.array([state.index_of("P-12")]), looks, sun=(0.3, 0.2))
>>> sorted(set(parts.layer.tolist())), POSES[int(pose_codes(state)[state.index_of("P-12")])]
([0, 1, 2, 3], 'lying')
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from flight.sim.scene import SceneState
from flight.sim.scene_model import BEHAVIOURS

from .palette import clothing_colours, hair_colours, skin_colours, uniforms, vehicle_colours
from .raster import BODY, FLAT, SHADOW

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

POSES: tuple[str, ...] = ("standing", "walking", "sitting", "lying")
_POSE_OF = {"walking": 1, "running": 1, "standing": 0, "sitting": 2, "resting": 3, "collapsed": 3}
SHADOW_LAYER, LEGS_LAYER, BODY_LAYER, HEAD_LAYER = 0, 1, 2, 3

# Per pose: (part, from forward, from up, to forward, to up, radius, layer, colour source) in metres for a body of
# the pose's default size (scaled by the actor's own box); colour 0 clothing, 1 skin, 2 hair.
_PARTS: dict[int, list[tuple[float, float, float, float, float, int, int]]] = {
    0: [(0.0, 0.30, 0.0, 1.40, 0.25, BODY_LAYER, 0), (0.03, 1.58, 0.03, 1.58, 0.11, HEAD_LAYER, 2)],
    1: [
        (-0.34, 0.10, 0.34, 0.10, 0.08, LEGS_LAYER, 1),
        (-0.06, 0.30, 0.06, 1.40, 0.23, BODY_LAYER, 0),
        (0.09, 1.58, 0.09, 1.58, 0.11, HEAD_LAYER, 2),
    ],
    2: [
        (0.0, 0.14, 0.42, 0.12, 0.12, LEGS_LAYER, 0),
        (-0.10, 0.25, -0.10, 0.70, 0.23, BODY_LAYER, 0),
        (-0.07, 0.88, -0.07, 0.88, 0.11, HEAD_LAYER, 2),
    ],
    3: [
        (-0.82, 0.10, -0.08, 0.10, 0.14, LEGS_LAYER, 0),
        (-0.08, 0.13, 0.50, 0.13, 0.23, BODY_LAYER, 0),
        (0.76, 0.11, 0.76, 0.11, 0.11, HEAD_LAYER, 1),
    ],
}
_REFERENCE = {0: (0.5, 0.5, 1.7), 1: (0.5, 0.5, 1.7), 2: (0.7, 0.6, 1.0), 3: (1.8, 0.6, 0.3)}


@dataclass(frozen=True)
class _Table:
    """One pose's parts as columns (:data:`_PARTS`), with each part's draw mode and the higher of its two ends."""

    f0: FloatArray
    u0: FloatArray
    f1: FloatArray
    u1: FloatArray
    radius: FloatArray
    layer: IntArray
    source: tuple[int, ...]
    mode: IntArray
    top: FloatArray

    @classmethod
    def of(cls, parts: list[tuple[float, float, float, float, float, int, int]]) -> _Table:
        f0, u0, f1, u1, radius = (np.array([p[k] for p in parts]) for k in range(5))
        layer = np.array([p[5] for p in parts], dtype=np.int64)
        mode = np.where(layer == HEAD_LAYER, FLAT, BODY).astype(np.int64)
        return cls(f0, u0, f1, u1, radius, layer, tuple(p[6] for p in parts), mode, np.maximum(u0, u1))


_TABLES = {pose: _Table.of(parts) for pose, parts in _PARTS.items()}


def pose_codes(state: SceneState) -> IntArray:
    """Each actor's pose as an index into :data:`POSES` (-1 for what is not a person)."""
    by_behaviour = np.array([_POSE_OF.get(b, -1) for b in BEHAVIOURS], dtype=np.int64)
    codes: IntArray = np.where(state.person_mask, by_behaviour[state.behaviour_codes], -1)
    return codes


class Looks:
    """Every actor's colours (clothing, skin, hair; a vehicle's paint), fixed by the seed and the actor's row and
    generation: a new pilgrim entering a flowing zone in an old one's row gets new clothes."""

    def __init__(self, state: SceneState, seed: int) -> None:
        self._state = state
        self._seed = seed
        n = len(state)
        self.clothing = np.zeros((n, 3))
        self.skin = np.zeros((n, 3))
        self.hair = np.zeros((n, 3))
        self.paint = np.zeros((n, 3))
        self._generation = np.full(n, -1, dtype=np.int64)

    def refresh(self, rows: IntArray) -> None:
        """Draw the looks of ``rows`` not drawn yet for their current generation."""
        stale = rows[self._generation[rows] != self._state.generations[rows]]
        if len(stale) == 0:
            return
        generations = self._state.generations[stale]
        u = uniforms(self._seed * 1_000_003 + self._state.scene.seed, stale, generations, 6)
        self.clothing[stale] = clothing_colours(u[:, :3])
        self.skin[stale] = skin_colours(u[:, 3])
        self.hair[stale] = hair_colours(u[:, 4])
        self.paint[stale] = vehicle_colours(u[:, 5])
        self._generation[stale] = generations


@dataclass(frozen=True)
class Parts:
    """Capsules in the world: from ``a`` to ``b`` (K×3 north/east/down), radius (m), colour, draw mode, layer, and
    the person (an index into the rows given) each belongs to."""

    a: FloatArray
    b: FloatArray
    radius: FloatArray
    rgb: FloatArray
    mode: IntArray
    layer: IntArray
    owner: IntArray


def person_parts(state: SceneState, rows: IntArray, looks: Looks, sun: tuple[float, float]) -> Parts:
    """The capsules of the persons in ``rows`` and their shadows; ``sun`` is the ground offset (north, east) of a
    shadow per metre of height."""
    looks.refresh(rows)
    codes = pose_codes(state)[rows]
    pieces: list[Parts] = []
    for pose, parts in _PARTS.items():
        sel = np.flatnonzero(codes == pose)
        if len(sel) == 0:
            continue
        r = rows[sel]
        ref = _REFERENCE[pose]
        size = state.sizes[r]
        along = size[:, 0] / ref[0] if pose == 3 else np.sqrt(size[:, 0] * size[:, 1] / (ref[0] * ref[1]))
        across = size[:, 1] / ref[1]
        up = size[:, 2] / ref[2]
        h = state.headings[r]
        fwd = np.column_stack([np.cos(h), np.sin(h)])
        base = state.positions[r]
        colours = (looks.clothing[r], looks.skin[r], looks.hair[r])
        table = _TABLES[pose]  # every part of every person of the pose at once, part after part
        a, b = (np.empty((len(parts), len(sel), 3)) for _ in range(2))
        a[:, :, :2] = base + (table.f0[:, None] * along)[:, :, None] * fwd
        a[:, :, 2] = -table.u0[:, None] * up
        b[:, :, :2] = base + (table.f1[:, None] * along)[:, :, None] * fwd
        b[:, :, 2] = -table.u1[:, None] * up
        radius = table.radius[:, None] * across
        pieces.append(
            Parts(
                a.reshape(-1, 3),
                b.reshape(-1, 3),
                radius.reshape(-1),
                np.concatenate([colours[source] for source in table.source]),
                np.repeat(table.mode, len(sel)),
                np.repeat(table.layer, len(sel)),
                np.concatenate([sel] * len(parts)).astype(np.int64, copy=False),
            )
        )
        top = np.maximum((table.top[:, None] * up + radius).max(axis=0), 0.0)
        shadow_a = np.column_stack([base, np.zeros(len(sel))])
        tip = base + (top[:, None] * np.array(sun)[None, :])
        if pose == 3:  # lying: the body's own outline, nudged away from the sun
            shadow_a = np.column_stack([base - 0.7 * along[:, None] * fwd + 0.15 * np.array(sun), np.zeros(len(sel))])
            tip = base + 0.6 * along[:, None] * fwd + 0.15 * np.array(sun)
        shadow_b = np.column_stack([tip, np.zeros(len(sel))])
        n, black = len(sel), np.zeros((len(sel), 3))
        mode, layer = np.full(n, SHADOW, dtype=np.int64), np.full(n, SHADOW_LAYER, dtype=np.int64)
        pieces.append(Parts(shadow_a, shadow_b, 0.22 * across, black, mode, layer, sel.astype(np.int64, copy=False)))
    if not pieces:
        empty = np.zeros((0, 3))
        none = np.zeros(0, dtype=np.int64)
        return Parts(empty, empty, np.zeros(0), empty, none, none, none)
    return Parts(*(np.concatenate([getattr(p, name) for p in pieces]) for name in Parts.__dataclass_fields__))


def vehicle_quads(state: SceneState, rows: IntArray, looks: Looks, sun: tuple[float, float]) -> tuple[FloatArray, ...]:
    """For the vehicles in ``rows``: their shadows, roofs and windscreens as world quadrilaterals (each M×4×3),
    and the roofs' colours (M×3)."""
    looks.refresh(rows)
    h = state.headings[rows]
    fwd = np.column_stack([np.cos(h), np.sin(h)])
    side = np.column_stack([-np.sin(h), np.cos(h)])
    length, width, height = (state.sizes[rows, k] for k in range(3))
    centre = state.positions[rows]

    def quad(f0: float, f1: float, s: float, up: FloatArray, shift: FloatArray) -> FloatArray:
        out = np.zeros((len(rows), 4, 3))
        for k, (fa, sa) in enumerate(((f0, -s), (f1, -s), (f1, s), (f0, s))):
            out[:, k, :2] = centre + (fa * length / 2)[:, None] * fwd + (sa * width / 2)[:, None] * side + shift
            out[:, k, 2] = -up
        return out

    sun_shift = height[:, None] * np.array(sun)[None, :]
    shadow = quad(-1.0, 1.0, 1.0, np.zeros(len(rows)), sun_shift * 0.5)
    shadow_far = quad(-1.0, 1.0, 1.0, np.zeros(len(rows)), sun_shift)
    roof = quad(-0.92, 0.92, 0.92, height, np.zeros((len(rows), 2)))
    screen = quad(0.25, 0.5, 0.85, height, np.zeros((len(rows), 2)))
    return shadow, shadow_far, roof, screen, looks.paint[rows]


def sun_offset(seed: int) -> tuple[float, float]:
    """The ground offset (north, east) of a shadow per metre of height, for a sun drawn from the seed (elevation
    35–75°, any azimuth)."""
    rng = np.random.default_rng([seed, 41])
    azimuth = rng.uniform(0.0, 2.0 * math.pi)
    elevation = math.radians(rng.uniform(45.0, 80.0))
    away = 1.0 / math.tan(elevation)
    return -math.cos(azimuth) * away, -math.sin(azimuth) * away


__all__ = ["POSES", "Looks", "Parts", "person_parts", "pose_codes", "sun_offset", "vehicle_quads"]
