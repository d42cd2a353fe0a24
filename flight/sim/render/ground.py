"""The ground as the camera sees it: every pixel's ray meets the ground plane (the ground-plane homography), and
takes the colour of the texel there from a map rasterised once per scene, tile by tile, and kept in a small cache.

Two levels of detail: fine tiles (:data:`FINE_M` per texel) where a pixel covers less than :data:`COARSE_FROM_M`
of ground, coarse ones (:data:`COARSE_M`) farther out; rays that miss the ground, or meet it beyond
:data:`MAX_RANGE_M`, see sky; distant ground fades into haze. Straight-down views at survey heights take the fast
path: fine tiles only, assembled into one mosaic reused while the view stays inside it, and each pixel's texel
found by a few array operations.

>>> from flight.sim.scene_file import load_scene
>>> from agentic_core.contracts.camera import CameraPose, CameraSpec
>>> ground = GroundMap(load_scene("scenes/hajj_emergency.yaml"))
>>> image = ground.view(CameraSpec(width_px=64, height_px=48), CameraPose(north_m=0, east_m=0, down_m=-30))
>>> image.shape, image.dtype.name
((48, 64, 3), 'uint8')
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np
from numpy.typing import NDArray

from agentic_core.contracts.camera import CameraPose, CameraSpec
from agentic_core.contracts.pinhole import rotation_world_from_camera
from flight.sim.scene_model import Scene

from .ground_tiles import TILE, GroundLayers
from .palette import HAZE, SKY

F32 = NDArray[np.float32]
FINE_M = 0.1
COARSE_M = 1.6
COARSE_FROM_M = 0.3
"""Ground metres per pixel beyond which a pixel reads the coarse tiles."""
MAX_RANGE_M = 1000.0
HAZE_M = 800.0
"""Distance over which the ground's contrast fades by 1/e into haze."""
MIN_HEIGHT_M = 0.05
"""A camera at or below the ground is rendered as if this high (a valid picture, never a division by zero)."""
CACHE_TILES = 160


class GroundMap:
    """A scene's ground, tiled and cached; :meth:`view` renders it for one camera pose. Not thread-safe."""

    def __init__(self, scene: Scene) -> None:
        self.layers = GroundLayers(scene)
        self._tiles: OrderedDict[tuple[float, int, int], NDArray[np.uint8]] = OrderedDict()
        self._mosaic: tuple[float, int, int, int, int, NDArray[np.uint8]] | None = None
        self._rays: dict[tuple[int, int, float], tuple[F32, F32]] = {}
        self._offset_key: tuple[int, int, float, bytes, float] | None = None
        self._offset: tuple[F32, F32] = (np.zeros((0, 0), np.float32), np.zeros((0, 0), np.float32))

    def view(self, spec: CameraSpec, pose: CameraPose) -> NDArray[np.uint8]:
        """The ground (and sky) as ``spec`` sees it from ``pose``: H×W×3 uint8."""
        dx, dy = self._camera_rays(spec)
        rot = rotation_world_from_camera(spec, pose).astype(np.float32)
        height = np.float32(max(-pose.down_m, MIN_HEIGHT_M))
        fast = self._straight_down(spec, pose, rot, height)
        if fast is not None:
            return fast
        down = rot[2, 0] * dx[None, :] + (rot[2, 1] * dy[:, None] + rot[2, 2])
        hit = down > 1e-4
        t = height / np.where(hit, down, np.float32(1.0))
        north = np.float32(pose.north_m) + t * (rot[0, 0] * dx[None, :] + (rot[0, 1] * dy[:, None] + rot[0, 2]))
        east = np.float32(pose.east_m) + t * (rot[1, 0] * dx[None, :] + (rot[1, 1] * dy[:, None] + rot[1, 2]))
        norm = np.sqrt(1.0 + dx[None, :] ** 2 + dy[:, None] ** 2, dtype=np.float32)
        distance = np.where(hit, t * norm, np.float32(np.inf)).astype(np.float32)
        f = np.float32(spec.focal_px)
        fine = hit & (distance / f <= COARSE_FROM_M)
        sky = ~hit | (distance > MAX_RANGE_M)
        image = np.empty((spec.height_px, spec.width_px, 3), dtype=np.uint8)
        image[...] = SKY
        coarse = ~fine & ~sky
        for res, mask in ((FINE_M, fine), (COARSE_M, coarse)):
            if mask.any():
                image[mask] = self._sample(res, north[mask], east[mask])
        if coarse.any():
            fade = np.exp(-distance[coarse] / np.float32(HAZE_M))[:, None]
            image[coarse] = (image[coarse] * fade + np.array(HAZE, np.float32) * (1.0 - fade)).astype(np.uint8)
        return image

    def _straight_down(
        self, spec: CameraSpec, pose: CameraPose, rot: F32, height: np.float32
    ) -> NDArray[np.uint8] | None:
        """The fast path, when every pixel sees fine ground: the image's corners bound the ground it sees (a
        pixel's range on a plane is largest at a corner), so one mosaic serves, and each pixel's texel index is
        a ratio of two affine functions of its column and row, evaluated with the constants folded in."""
        dx, dy = self._camera_rays(spec)
        cx = np.array([dx[0], dx[-1], dx[-1], dx[0]], dtype=np.float32)
        cy = np.array([dy[0], dy[0], dy[-1], dy[-1]], dtype=np.float32)
        down = rot[2, 0] * cx + rot[2, 1] * cy + rot[2, 2]
        if not bool((down > 1e-3).all()):
            return None
        t = height / down
        if float((t * np.sqrt(1.0 + cx * cx + cy * cy)).max()) / spec.focal_px > COARSE_FROM_M:
            return None
        inv = np.float32(1.0 / FINE_M)
        north = (np.float32(pose.north_m) + t * (rot[0, 0] * cx + rot[0, 1] * cy + rot[0, 2])) * inv
        east = (np.float32(pose.east_m) + t * (rot[1, 0] * cx + rot[1, 1] * cy + rot[1, 2])) * inv
        _, mr0, _, mc0, _, mosaic = self._mosaic_for(
            int(np.floor(north.min())), int(np.floor(north.max())), int(np.floor(east.min())), int(np.floor(east.max()))
        )
        row0, col0 = np.float32(pose.north_m * inv - mr0 * TILE), np.float32(pose.east_m * inv - mc0 * TILE)
        rows, cols = self._offsets(spec, rot, height * inv)
        flat = np.add(rows, row0).astype(np.intp)  # the texel indices stay far inside int32: the mosaic bounds them
        flat *= mosaic.shape[1]
        flat += np.add(cols, col0).astype(np.intp)
        np.clip(flat, 0, mosaic.shape[0] * mosaic.shape[1] - 1, out=flat)
        image: NDArray[np.uint8] = np.take(mosaic.reshape(-1, 3), flat, axis=0)
        return image

    def _offsets(self, spec: CameraSpec, rot: F32, k: np.float32) -> tuple[F32, F32]:
        """Each pixel's texel row and column relative to the camera's own, straight down: they depend only on the
        spec, the attitude and the height (``k`` texels), so a level flight reuses the last ones."""
        key = (spec.width_px, spec.height_px, spec.hfov_deg, rot.tobytes(), float(k))
        if self._offset_key != key:
            dx, dy = self._camera_rays(spec)
            den = rot[2, 0] * dx[None, :] + (rot[2, 1] * dy[:, None] + rot[2, 2])
            scale = k / den
            rows = (rot[0, 0] * dx[None, :] + (rot[0, 1] * dy[:, None] + rot[0, 2])) * scale
            cols = (rot[1, 0] * dx[None, :] + (rot[1, 1] * dy[:, None] + rot[1, 2])) * scale
            self._offset_key, self._offset = key, (rows, cols)
        return self._offset

    def _mosaic_for(self, r0: int, r1: int, c0: int, c1: int) -> tuple[float, int, int, int, int, NDArray[np.uint8]]:
        """A fine mosaic covering texel rows ``r0``–``r1`` and columns ``c0``–``c1``: the last one if it does, else
        a new one with a tile's margin all round."""
        t0, t1, u0, u1 = r0 // TILE, r1 // TILE, c0 // TILE, c1 // TILE
        m = self._mosaic
        if m is None or t0 < m[1] or t1 > m[2] or u0 < m[3] or u1 > m[4]:
            m = self._assemble(FINE_M, t0 - 1, t1 + 1, u0 - 1, u1 + 1)
            self._mosaic = m
        return m

    def _camera_rays(self, spec: CameraSpec) -> tuple[F32, F32]:
        key = (spec.width_px, spec.height_px, spec.hfov_deg)
        if key not in self._rays:
            f = spec.focal_px
            cx, cy = spec.principal_point
            dx = ((np.arange(spec.width_px) + 0.5 - cx) / f).astype(np.float32)
            dy = ((np.arange(spec.height_px) + 0.5 - cy) / f).astype(np.float32)
            self._rays[key] = (dx, dy)
        return self._rays[key]

    def _sample(self, res: float, north: F32, east: F32) -> NDArray[np.uint8]:
        """The texel colours under ground points (any shape), from a mosaic of the tiles they need."""
        inv = np.float32(1.0 / res)
        rows = np.floor(north * inv).astype(np.int64)
        cols = np.floor(east * inv).astype(np.int64)
        r0, r1 = int(rows.min()) // TILE, int(rows.max()) // TILE
        c0, c1 = int(cols.min()) // TILE, int(cols.max()) // TILE
        m = self._assemble(res, r0, r1, c0, c1)
        _, mr0, _, mc0, _, mosaic = m
        flat = (rows - mr0 * TILE) * mosaic.shape[1] + (cols - mc0 * TILE)
        rgb: NDArray[np.uint8] = np.take(mosaic.reshape(-1, 3), flat, axis=0)
        return rgb

    def _assemble(
        self, res: float, r0: int, r1: int, c0: int, c1: int
    ) -> tuple[float, int, int, int, int, NDArray[np.uint8]]:
        mosaic = np.empty(((r1 - r0 + 1) * TILE, (c1 - c0 + 1) * TILE, 3), dtype=np.uint8)
        for i in range(r0, r1 + 1):
            for j in range(c0, c1 + 1):
                block = (i - r0) * TILE, (j - c0) * TILE
                mosaic[block[0] : block[0] + TILE, block[1] : block[1] + TILE] = self._tile(res, i, j)
        return res, r0, r1, c0, c1, mosaic

    def _tile(self, res: float, i: int, j: int) -> NDArray[np.uint8]:
        key = (res, i, j)
        tile = self._tiles.get(key)
        if tile is None:
            tile = self.layers.tile(res, i, j)
            self._tiles[key] = tile
            if len(self._tiles) > CACHE_TILES:
                self._tiles.popitem(last=False)
        else:
            self._tiles.move_to_end(key)
        return tile


__all__ = ["COARSE_M", "FINE_M", "MAX_RANGE_M", "GroundMap"]
