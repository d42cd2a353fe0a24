"""The picture under the console's map: a run's scene rendered straight down (the ground only, as the camera
paints it), as PNG bytes, and its bounds in latitude and longitude; pictures kept per scene digest, a few at most.

>>> from flight.sim.scene_file import load_scene
>>> scene = load_scene("scenes/hajj_emergency.yaml")
>>> (south, west), (north, east) = ground_bounds(scene)
>>> south < scene.home.lat_deg < north and west < scene.home.lon_deg < east
True
>>> GroundPictures().png(scene)[:4] == b"\\x89PNG"
True
"""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict

from flight.sim.render.orthophoto import orthophoto_extent, render_orthophoto
from flight.sim.render.png import png_bytes
from flight.sim.scene_model import Scene

from ..contracts.geodesy import offset_position

M_PER_PX = 1.0
"""The console's picture: a metre per pixel (about 600 KB for the Hajj scenes), coarser for a larger scene."""
KEPT = 4
"""Pictures kept in memory (one per scene digest), the least recently served dropped first."""


def ground_bounds(scene: Scene) -> list[list[float]]:
    """The picture's south-west and north-east corners as ``[[lat, lon], [lat, lon]]`` (Leaflet's bounds)."""
    extent = orthophoto_extent(scene, M_PER_PX)
    home = scene.home
    corners = ((extent.south_m, extent.west_m), (extent.north_m, extent.east_m))
    return [[round(v, 7) for v in offset_position(home.lat_deg, home.lon_deg, n, e)] for n, e in corners]


def scene_digest(scene: Scene) -> str:
    """What identifies a scene's picture: the SHA-256 of the scene as JSON."""
    return hashlib.sha256(scene.model_dump_json().encode()).hexdigest()


class GroundPictures:
    """Scenes' ground pictures as PNG, rendered once per scene digest and the last :data:`KEPT` kept."""

    def __init__(self, kept: int = KEPT) -> None:
        self.kept = kept
        self._pictures: OrderedDict[str, bytes] = OrderedDict()
        self._lock = threading.Lock()

    def png(self, scene: Scene) -> bytes:
        """The PNG of ``scene``'s ground over :func:`ground_bounds`, north up."""
        key = scene_digest(scene)
        with self._lock:
            if key in self._pictures:
                self._pictures.move_to_end(key)
                return self._pictures[key]
        data = png_bytes(render_orthophoto(scene, M_PER_PX).image)
        with self._lock:
            self._pictures[key] = data
            while len(self._pictures) > self.kept:
                self._pictures.popitem(last=False)
        return data


__all__ = ["KEPT", "M_PER_PX", "GroundPictures", "ground_bounds", "scene_digest"]
