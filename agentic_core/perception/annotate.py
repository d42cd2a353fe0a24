"""An annotated picture of one frame, as PNG: for alerts ("annotated imagery") and mission reports.

Drawn in the image plane of the frame: the frame's pixels when it has some (a real camera, or the simulated one
rendering: ``--render``), else a plain ground; every detection's box; each tracked object's box (the one its last
detection had, else a marker where its position projects) with its id; the casualties highlighted in red with
what makes them so (by default: the objects both ``stationary`` and ``isolated_from`` the crowd) and their
position (latitude, longitude) under them; a scale bar in metres (the ground sample distance at the image centre,
exact over flat ground for the default straight-down camera); and a caption with the time, frame, object count
and any degraded sensors.

The picture is on an alert's critical path (the frame that confirms a casualty to the alert sent), so it is drawn
straight into a numpy RGB array rather than through matplotlib's figure machinery, which took tens of
milliseconds to lay out and draw a frame: boxes and markers are filled pixel spans written in a few vectorised
operations, text is composed from glyphs FreeType renders once per font, size and character (matplotlib's own
DejaVu Sans through :class:`matplotlib.ft2font.FT2Font`, so labels look as before), and the PNG is encoded here
with :mod:`zlib` at its fastest level (lossless; a frame compresses well). Sizes are given in points at 100 dpi,
as the figure had them. No global state but the glyph cache (guarded by a lock), so it is safe in a headless run
and from any thread.

>>> from agentic_core.contracts.camera import CameraPose, CameraSpec, Frame
>>> from agentic_core.perception.world_model import WorldModel
>>> frame = Frame(index=0, time_s=0.0, spec=CameraSpec(), pose=CameraPose(north_m=0, east_m=0, down_m=-30))
>>> world = WorldModel.model_validate({"timestamp": 0.0, "ego_pose": {"north": 0, "east": 0, "down": -30,
...     "lat": 21.4133, "lon": 39.8933, "alt": 330}})
>>> png = annotate_frame(frame, world, width_px=320)
>>> png[:8] == b"\\x89PNG\\r\\n\\x1a\\n"
True
"""

from __future__ import annotations

import functools
import math
import struct
import threading
import zlib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from itertools import accumulate
from pathlib import Path
from typing import Any, Literal

import numpy as np
from matplotlib import ft2font, get_data_path
from numpy.typing import NDArray

from agentic_core.contracts.camera import BoundingBox, Detection, Frame
from agentic_core.contracts.pinhole import ground_points, ground_sample_distance, project_points

from .world_model import WorldModel

RGB = tuple[int, int, int]
Image = NDArray[np.uint8]
"""An H×W×3 RGB picture."""

_NICE_M = (0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 500.0)
_TRACK: RGB = (0x35, 0xC0, 0xFF)
_CASUALTY: RGB = (0xFF, 0x2D, 0x2D)
_DETECTION: RGB = (0xD8, 0xD8, 0xD8)
_GROUND: RGB = (0x6B, 0x62, 0x56)
_WHITE: RGB = (0xFF, 0xFF, 0xFF)
_BLACK: RGB = (0, 0, 0)
_DPI = 100.0
"""Pixels per inch: line widths, marker and font sizes are in points (1/72 inch), as they were in the figure."""


def casualties_of(world: WorldModel) -> list[str]:
    """The ids of objects that are both ``stationary`` and ``isolated_from`` something: the default highlight."""
    still = {r.subj for r in world.relations if r.pred == "stationary"}
    isolated = {r.subj for r in world.relations if r.pred == "isolated_from"}
    return [o.id for o in world.objects if o.id in still and o.id in isolated]


def position_text(lat: float, lon: float) -> str:
    """A position as the picture writes it: ``21.42250° N, 39.87330° E`` (five decimals: about a metre).

    >>> position_text(21.4225, -39.8733)
    '21.42250° N, 39.87330° W'
    """
    return f"{abs(lat):.5f}° {'N' if lat >= 0 else 'S'}, {abs(lon):.5f}° {'E' if lon >= 0 else 'W'}"


def scale_bar_m(metres_per_px: float, image_width_px: float) -> float:
    """A round length (m) whose bar spans about a fifth of the image: 0.5, 1, 2, 5, 10, 20, ... metres."""
    target = metres_per_px * image_width_px / 5.0
    return min(_NICE_M, key=lambda m: abs(math.log(m / target)))


def annotate_frame(
    frame: Frame,
    world: WorldModel,
    *,
    detections: Sequence[Detection] = (),
    boxes: Mapping[str, BoundingBox] | None = None,
    highlight: Iterable[str] | None = None,
    path: str | Path | None = None,
    width_px: int = 960,
    max_labels: int = 60,
) -> bytes:
    """The frame annotated as PNG bytes (also written to ``path`` if given).

    ``boxes`` maps object ids to their box in this frame (:meth:`.pipeline.Perception.track_boxes`); objects
    without one get a marker where their position projects. ``highlight``: the ids to mark as casualties
    (default :func:`casualties_of`). Ids are written when at most ``max_labels`` objects are in the picture (a
    crowd's labels would hide it); casualties' always.
    """
    spec = frame.spec
    scale = width_px / spec.width_px
    height_px = max(1, round(spec.height_px * scale))
    canvas = _Canvas(_background(frame.image, height_px, width_px), scale)
    font = max(6.0, 11.0 * width_px / 960.0)  # by the picture's width, whatever the camera's resolution
    canvas.outlines([d.box for d in detections], _DETECTION, 0.8)
    marked = set(casualties_of(world) if highlight is None else highlight)
    objects = [o for o in world.objects if o.state != "lost"]
    known = boxes or {}
    canvas.outlines([known[o.id] for o in objects if o.id in known and o.id not in marked], _TRACK, 1.2)

    # where each object is drawn: the top-left of its box, else a marker where its position projects
    anchors: dict[str, tuple[float, float, BoundingBox | None]] = {}
    unboxed = [o for o in objects if o.id not in known]
    if unboxed:
        points = np.array([[o.pose.north, o.pose.east, o.pose.down] for o in unboxed], dtype=float)
        pixels, visible = project_points(spec, frame.pose, points)
        for o, (u, v), seen in zip(unboxed, pixels.tolist(), visible.tolist(), strict=True):
            if seen:
                anchors[o.id] = (u, v, None)
    for o in objects:
        if o.id in known:
            known_box = known[o.id]
            anchors[o.id] = (known_box.x_min, known_box.y_min, known_box)
    show_labels = len(objects) <= max_labels
    for casualty in (False, True):  # casualties drawn last, on top
        group = [o for o in objects if o.id in anchors and (o.id in marked) == casualty]
        color = _CASUALTY if casualty else _TRACK
        if casualty:  # the others' boxes are drawn together, before
            canvas.outlines([known[o.id] for o in group if o.id in known], color, 3.0)
        canvas.disks([anchors[o.id][:2] for o in group if o.id not in known], 8.0 if casualty else 4.0, color)
        if not (casualty or show_labels):
            continue
        for o in group:
            x, y, box = anchors[o.id]
            label = o.id
            if casualty:
                isolated = next((r.value for r in world.relations_of(o.id) if r.pred == "isolated_from"), None)
                apart = f", {isolated:.0f} m from anyone" if isolated is not None else ""
                label = f"{o.id}: still {o.stationary_s:.1f} s{apart}, conf {o.conf:.2f}"
            right = x > 0.6 * spec.width_px  # keep long labels inside the picture
            canvas.text(
                x + (box.width if right and box is not None else 0.0),
                max(y - 4, 4 * font),
                label,
                color=color,
                size_pt=font * (1.2 if casualty else 0.8),
                bold=casualty,
                ha="right" if right else "left",
                va="bottom",
                box_alpha=0.5 if casualty else None,
                pad_pt=1.0,
            )
            if casualty:  # where to go, under the casualty
                below = box.y_max if box is not None else y + 8.0
                canvas.text(
                    x + (box.width if right and box is not None else 0.0), min(below + 4, spec.height_px - 4 * font),
                    position_text(o.pose.lat, o.pose.lon), color=color, size_pt=font, bold=True,
                    ha="right" if right else "left", va="top", box_alpha=0.5, pad_pt=1.0,
                )  # fmt: skip
    _scale_bar(canvas, frame, scale, font)
    degraded = f" · degraded: {', '.join(world.health.degraded_sensors)}" if world.health.degraded_sensors else ""
    caption = f"t={world.timestamp:.2f} s · frame {world.frame} · {len(objects)} objects{degraded}"
    canvas.text(8, 8, caption, color=_WHITE, size_pt=font, ha="left", va="top", box_alpha=0.55, pad_pt=2.0)
    png = encode_png(canvas.pixels)
    if path is not None:
        Path(path).write_bytes(png)
    return png


def encode_png(pixels: Image, level: int = 1) -> bytes:
    """An H×W×3 RGB array as PNG bytes: each row "Up"-filtered (the difference from the row above, so flat ground
    and long edges become runs of zeros) and deflated at ``level`` (1: the fastest; still lossless)."""
    height, width, _ = pixels.shape
    rows = pixels.reshape(height, width * 3)
    raw = np.empty((height, width * 3 + 1), dtype=np.uint8)
    raw[:, 0] = 2  # filter type Up
    raw[0, 1:] = rows[0]
    np.subtract(rows[1:], rows[:-1], out=raw[1:, 1:])  # modulo 256, as the filter is defined
    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)  # 8-bit RGB, no interlace
    return b"".join(
        (
            b"\x89PNG\r\n\x1a\n",
            _chunk(b"IHDR", header),
            _chunk(b"IDAT", zlib.compress(raw.data, level)),
            _chunk(b"IEND", b""),
        )
    )


def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def _background(image: Image | None, height: int, width: int) -> Image:
    """The frame's pixels resampled (nearest neighbour) to ``height``×``width``, else the plain ground."""
    if image is None:
        canvas = np.empty((height, width, 3), dtype=np.uint8)
        canvas[0] = _GROUND
        canvas[1:] = canvas[0]  # whole rows: much faster than broadcasting three bytes over every pixel
        return canvas
    pixels = np.asarray(image)
    if pixels.ndim == 2:  # grey
        pixels = np.repeat(pixels[:, :, None], 3, axis=2)
    pixels = pixels[:, :, :3]
    if pixels.dtype != np.uint8:
        pixels = np.clip(pixels, 0, 255).astype(np.uint8)
    rows = ((np.arange(height) + 0.5) * pixels.shape[0] / height).astype(np.intp)
    cols = ((np.arange(width) + 0.5) * pixels.shape[1] / width).astype(np.intp)
    return np.ascontiguousarray(pixels[rows[:, None], cols[None, :]])


def _spans(starts: NDArray[np.intp], lengths: NDArray[np.intp]) -> NDArray[np.intp]:
    """The concatenation of ``range(start, start + length)`` for every pair, without a Python loop."""
    total = int(lengths.sum())
    if total == 0:
        return np.zeros(0, dtype=np.intp)
    ends = np.cumsum(lengths)
    return np.repeat(starts - ends + lengths, lengths) + np.arange(total, dtype=np.intp)


class _Canvas:
    """An RGB picture being drawn on, in the frame's pixel coordinates times ``scale``."""

    def __init__(self, pixels: Image, scale: float) -> None:
        self.pixels = pixels
        self.scale = scale
        self.height, self.width = pixels.shape[:2]

    def fill_rects(self, rects: NDArray[np.intp], color: RGB) -> None:
        """Fill N pixel rectangles (N×4 ``x0, y0, x1, y1``, ends exclusive) with one colour, clipped to the
        picture, in one indexed assignment."""
        if len(rects) == 0:
            return
        low = np.maximum(rects, 0)  # np.clip does the same, but looks up its dtype's limits on every call
        x0 = np.minimum(low[:, 0], self.width)
        x1 = np.minimum(low[:, 2], self.width)
        y0 = np.minimum(low[:, 1], self.height)
        y1 = np.minimum(low[:, 3], self.height)
        keep = (x1 > x0) & (y1 > y0)
        x0, x1, y0, y1 = x0[keep], x1[keep], y0[keep], y1[keep]
        rows = y1 - y0
        which = np.repeat(np.arange(len(rows)), rows)  # one entry per row of every rectangle
        y = _spans(y0, rows)
        flat = _spans(y * self.width + x0[which], (x1 - x0)[which])
        self.pixels.reshape(-1, 3)[flat] = color

    def outlines(self, boxes: Sequence[BoundingBox], color: RGB, width_pt: float) -> None:
        """Box outlines ``width_pt`` thick, centred on each box's edges: one vectorised fill for a whole crowd."""
        if not boxes:
            return
        line = max(1, round(width_pt * _DPI / 72.0))
        half = line / 2.0
        corners = np.array([(b.x_min, b.y_min, b.x_max, b.y_max) for b in boxes], dtype=float) * self.scale
        x0 = np.round(corners[:, 0] - half).astype(np.intp)
        y0 = np.round(corners[:, 1] - half).astype(np.intp)
        x1 = np.maximum(np.round(corners[:, 2] + half).astype(np.intp), x0 + 2 * line)
        y1 = np.maximum(np.round(corners[:, 3] + half).astype(np.intp), y0 + 2 * line)
        n = len(boxes)
        edges = np.empty((4, n, 4), dtype=np.intp)  # top, bottom, left, right; each x0, y0, x1, y1
        edges[:, :, 0] = x0
        edges[:, :, 1] = y0
        edges[:, :, 2] = x1
        edges[:, :, 3] = y1
        edges[0, :, 3] = y0 + line
        edges[1, :, 1] = y1 - line
        edges[2, :, 2] = x0 + line
        edges[3, :, 0] = x1 - line
        self.fill_rects(edges.reshape(4 * n, 4), color)

    def disks(self, centres: Sequence[tuple[float, float]], size_pt: float, color: RGB) -> None:
        """Filled round markers ``size_pt`` across, centred on frame pixels."""
        if not centres:
            return
        radius = (size_pt + 1.0) * _DPI / 72.0 / 2.0  # matplotlib's marker: its size plus a 1 pt edge
        reach = math.ceil(radius)
        dy, dx = np.mgrid[-reach : reach + 1, -reach : reach + 1]
        inside = dx**2 + dy**2 <= radius**2
        offsets = np.stack([dx[inside], dy[inside]], axis=1)
        at = np.round(np.array(centres, dtype=float) * self.scale).astype(np.intp)
        points = (at[:, None, :] + offsets[None, :, :]).reshape(-1, 2)
        keep = (points[:, 0] >= 0) & (points[:, 0] < self.width) & (points[:, 1] >= 0) & (points[:, 1] < self.height)
        points = points[keep]
        self.pixels[points[:, 1], points[:, 0]] = color

    def blend_rect(self, x0: int, y0: int, x1: int, y1: int, color: RGB, alpha: float) -> None:
        """``color`` laid over a rectangle with opacity ``alpha`` (a label's translucent background)."""
        x0, x1 = max(0, x0), min(self.width, x1)
        y0, y1 = max(0, y0), min(self.height, y1)
        if x1 <= x0 or y1 <= y0:
            return
        region = self.pixels[y0:y1, x0:x1]
        blended = region * (1.0 - alpha) + np.asarray(color, dtype=float) * alpha
        region[...] = np.round(blended).astype(np.uint8)

    def text(
        self,
        x: float,
        y: float,
        text: str,
        *,
        color: RGB,
        size_pt: float,
        bold: bool = False,
        ha: Literal["left", "center", "right"] = "left",
        va: Literal["top", "bottom"] = "bottom",
        box_alpha: float | None = None,
        pad_pt: float = 0.0,
    ) -> None:
        """One line of text anchored at frame pixel (``x``, ``y``) as matplotlib's ``ha``/``va`` place it, on a
        translucent black box ``pad_pt`` wider all round when ``box_alpha`` is given."""
        if not text:
            return
        face = _face(size_pt, bold)
        glyphs = [face.glyph(ch) for ch in text]
        pens = list(accumulate((g.advance for g in glyphs), initial=0))
        advance = pens.pop()
        height = face.ascent + face.descent
        left = round(x * self.scale - {"left": 0.0, "center": advance / 2.0, "right": float(advance)}[ha])
        top = round(y * self.scale - (0.0 if va == "top" else height))
        if box_alpha is not None:
            pad = round(pad_pt * _DPI / 72.0)
            self.blend_rect(left - pad, top - pad, left + advance + pad, top + height + pad, _BLACK, box_alpha)
        # the glyphs' coverage composed into one mask, then blended once
        below = max([face.descent] + [g.height - g.bearing_y for g in glyphs])
        above = max([face.ascent] + [g.bearing_y for g in glyphs])
        margin = max([0] + [-g.bearing_x for g in glyphs])  # ink left of the first pen (a negative bearing)
        right = max([advance] + [p + g.bearing_x + g.width for p, g in zip(pens, glyphs, strict=True)])
        mask = np.zeros((above + below, margin + right), dtype=np.uint8)
        for pen, g in zip(pens, glyphs, strict=True):
            if g.coverage.size:
                row, col = above - g.bearing_y, margin + pen + g.bearing_x
                target = mask[row : row + g.height, col : col + g.width]
                np.maximum(target, g.coverage, out=target)
        self.blend_mask(left - margin, top + face.ascent - above, mask, color)

    def blend_mask(self, left: int, top: int, mask: Image, color: RGB) -> None:
        """``color`` laid over the picture with the coverage ``mask`` (0–255) as opacity, its corner at
        (``left``, ``top``), clipped to the picture."""
        x0, y0 = max(0, left), max(0, top)
        x1, y1 = min(self.width, left + mask.shape[1]), min(self.height, top + mask.shape[0])
        if x1 <= x0 or y1 <= y0:
            return
        alpha = mask[y0 - top : y1 - top, x0 - left : x1 - left, None] * (1.0 / 255.0)
        region = self.pixels[y0:y1, x0:x1]
        blended = region + (np.asarray(color, dtype=float) - region) * alpha
        region[...] = np.round(blended).astype(np.uint8)


@dataclass(frozen=True)
class _Glyph:
    """One character rendered: its coverage bitmap, where that sits from the pen on the baseline, the advance."""

    coverage: Image
    bearing_x: int
    bearing_y: int
    advance: int
    """In whole pixels (hinted), as matplotlib lays out a line."""

    @functools.cached_property
    def width(self) -> int:
        return int(self.coverage.shape[1])

    @functools.cached_property
    def height(self) -> int:
        return int(self.coverage.shape[0])


class _Face:
    """DejaVu Sans (matplotlib's default font, shipped with it) at one size, its glyphs rendered once each."""

    def __init__(self, size_pt: float, bold: bool) -> None:
        name = "DejaVuSans-Bold.ttf" if bold else "DejaVuSans.ttf"
        self._font = ft2font.FT2Font(str(Path(get_data_path()) / "fonts" / "ttf" / name))
        self._font.set_size(size_pt, _DPI)
        self._glyphs: dict[str, _Glyph] = {}
        tall, deep = self.glyph("l"), self.glyph("p")  # a line's extent, as matplotlib measures it ("lp")
        self.ascent = tall.bearing_y
        self.descent = deep.height - deep.bearing_y

    def glyph(self, ch: str) -> _Glyph:
        """``ch`` rendered (once; then from the cache)."""
        found = self._glyphs.get(ch)
        if found is not None:
            return found
        with _FONT_LOCK:  # FT2Font is not thread-safe
            font = self._font
            metrics = font.load_char(ord(ch), flags=_HINTING)
            font.set_text(ch, 0.0, flags=_HINTING)
            font.draw_glyphs_to_bitmap(antialiased=True)
            bitmap = np.asarray(font.get_image(), dtype=np.uint8)
        ink_rows, ink_cols = np.flatnonzero(bitmap.any(axis=1)), np.flatnonzero(bitmap.any(axis=0))
        if len(ink_rows):
            coverage = bitmap[ink_rows[0] : ink_rows[-1] + 1, ink_cols[0] : ink_cols[-1] + 1].copy()
        else:  # a space
            coverage = np.zeros((0, 0), dtype=np.uint8)
        glyph = _Glyph(
            coverage=coverage,
            bearing_x=round(metrics.horiBearingX / 64.0),
            bearing_y=round(metrics.horiBearingY / 64.0),
            advance=round(metrics.horiAdvance / 64.0),
        )
        self._glyphs[ch] = glyph
        return glyph


_HINTING: Any = ft2font.LoadFlags.DEFAULT if hasattr(ft2font, "LoadFlags") else 0  # FT_LOAD_DEFAULT before 3.10
"""FreeType's default hinting (the font's own instructions): matplotlib's default ``text.hinting``."""
_FONT_LOCK = threading.RLock()
_FACES: dict[tuple[float, bool], _Face] = {}


def _face(size_pt: float, bold: bool) -> _Face:
    """The face at ``size_pt`` (rounded to a tenth of a point), made once."""
    key = (round(size_pt, 1), bold)
    face = _FACES.get(key)
    if face is None:
        with _FONT_LOCK:
            face = _FACES.get(key)
            if face is None:
                face = _FACES[key] = _Face(*key)
    return face


def _scale_bar(canvas: _Canvas, frame: Frame, scale: float, font: float) -> None:
    spec, pose = frame.spec, frame.pose
    cx, cy = spec.principal_point
    ground, hit = ground_points(spec, pose, np.array([[cx, cy]]))
    if not bool(hit[0]):
        return
    centre = np.array([[ground[0, 0], ground[0, 1], 0.0]])
    metres_per_px = float(ground_sample_distance(spec, pose, centre)[0])
    length_m = scale_bar_m(metres_per_px, spec.width_px)
    length_px = length_m / metres_per_px
    x0, y0 = 0.04 * spec.width_px, 0.93 * spec.height_px
    thick = max(6.0, 8.0 / scale)
    bar = np.array([[x0, y0, x0 + length_px, y0 + thick]]) * scale
    outer = np.round(bar).astype(np.intp)
    outer[:, 2:] = np.maximum(outer[:, 2:], outer[:, :2] + 3)
    canvas.fill_rects(outer, _BLACK)  # a white bar with a black edge
    canvas.fill_rects(outer + np.array([1, 1, -1, -1]), _WHITE)
    text = f"{length_m:g} m"
    canvas.text(x0 + length_px / 2, y0 - 4, text, color=_WHITE, size_pt=font, ha="center", va="bottom")


__all__ = ["annotate_frame", "casualties_of", "encode_png", "position_text", "scale_bar_m"]
