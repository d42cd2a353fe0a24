"""An annotated picture of one frame, as PNG: for alerts ("annotated imagery") and mission reports.

Drawn in the image plane of the frame: the frame's pixels when it has some (a real camera), else a plain ground
(the simulated camera has none); every detection's box; each tracked object's box (the one its last detection
had, else a marker where its position projects) with its id; the casualties highlighted in red with what makes
them so (by default: the objects both ``stationary`` and ``isolated_from`` the crowd); a scale bar in metres (the
ground sample distance at the image centre, exact over flat ground for the default straight-down camera); and a
caption with the time, frame, object count and any degraded sensors.

Rendering uses matplotlib's Agg canvas directly (no pyplot, no display, no global state), so it is safe in a
headless run and from any thread.

>>> from flight.camera import CameraPose, CameraSpec, Frame
>>> from agentic_core.perception.world_model import WorldModel
>>> frame = Frame(index=0, time_s=0.0, spec=CameraSpec(), pose=CameraPose(north_m=0, east_m=0, down_m=-30))
>>> world = WorldModel.model_validate({"timestamp": 0.0, "ego_pose": {"north": 0, "east": 0, "down": -30,
...     "lat": 21.4133, "lon": 39.8933, "alt": 330}})
>>> png = annotate_frame(frame, world, width_px=320)
>>> png[:8] == b"\\x89PNG\\r\\n\\x1a\\n"
True
"""

from __future__ import annotations

import io
import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from flight.camera import BoundingBox, Detection, Frame, ground_points, ground_sample_distance, project_points

from .world_model import WorldModel, WorldObject

_NICE_M = (0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 500.0)
_TRACK, _CASUALTY, _DETECTION = "#35c0ff", "#ff2d2d", "#d8d8d8"


def casualties_of(world: WorldModel) -> list[str]:
    """The ids of objects that are both ``stationary`` and ``isolated_from`` something: the default highlight."""
    still = {r.subj for r in world.relations if r.pred == "stationary"}
    return [o.id for o in world.objects if o.id in still and world.has(o.id, "isolated_from")]


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
    fig = Figure(figsize=(width_px / 100.0, height_px / 100.0), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.add_axes((0.0, 0.0, 1.0, 1.0))
    ax.set_xlim(0, spec.width_px)
    ax.set_ylim(spec.height_px, 0)
    ax.set_axis_off()
    if frame.image is not None:
        ax.imshow(frame.image, extent=(0, spec.width_px, spec.height_px, 0))
    else:
        ax.add_patch(Rectangle((0, 0), spec.width_px, spec.height_px, color="#6b6256"))
    font = max(6.0, 11.0 * scale * 2.0)
    _boxes(ax, [d.box for d in detections], _DETECTION, 0.8)
    marked = set(casualties_of(world) if highlight is None else highlight)
    objects = [o for o in world.objects if o.state != "lost"]
    known = boxes or {}
    _boxes(ax, [known[o.id] for o in objects if o.id in known and o.id not in marked], _TRACK, 1.2)
    for o in sorted(objects, key=lambda o: o.id in marked):  # casualties drawn last, on top
        _object(ax, frame, o, known.get(o.id), o.id in marked, world, font, len(objects) <= max_labels)
    _scale_bar(ax, frame, scale, font)
    degraded = f" · degraded: {', '.join(world.health.degraded_sensors)}" if world.health.degraded_sensors else ""
    caption = f"t={world.timestamp:.2f} s · frame {world.frame} · {len(objects)} objects{degraded}"
    ax.text(
        8,
        8,
        caption,
        color="white",
        fontsize=font,
        va="top",
        ha="left",
        bbox={"facecolor": "black", "alpha": 0.55, "pad": 2, "edgecolor": "none"},
    )
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=100, pil_kwargs={"compress_level": 1})  # fast to write; still lossless
    png = buffer.getvalue()
    if path is not None:
        Path(path).write_bytes(png)
    return png


def _box(ax: object, box: BoundingBox, color: str, width: float) -> None:
    _boxes(ax, [box], color, width)


def _boxes(ax: object, boxes: Sequence[BoundingBox], color: str, width: float) -> None:
    """Box outlines as one line collection: one artist for a crowd, not one per person."""
    if not boxes:
        return
    outlines = [
        [(b.x_min, b.y_min), (b.x_max, b.y_min), (b.x_max, b.y_max), (b.x_min, b.y_max), (b.x_min, b.y_min)]
        for b in boxes
    ]
    ax.add_collection(LineCollection(outlines, colors=color, linewidths=width))  # type: ignore[attr-defined]


def _object(
    ax: object,
    frame: Frame,
    o: WorldObject,
    box: BoundingBox | None,
    casualty: bool,
    world: WorldModel,
    font: float,
    show_label: bool,
) -> None:
    color = _CASUALTY if casualty else _TRACK
    if box is not None:
        if casualty:  # the others' boxes are drawn together, before
            _box(ax, box, color, 3.0)
        x, y = box.x_min, box.y_min
    else:
        pixels, visible = project_points(frame.spec, frame.pose, np.array([[o.pose.north, o.pose.east, o.pose.down]]))
        if not bool(visible[0]):
            return
        u, v = pixels[0]
        ax.plot([u], [v], marker="o", markersize=8 if casualty else 4, color=color)  # type: ignore[attr-defined]
        x, y = float(u), float(v)
    label = o.id
    if casualty:
        isolated = next((r.value for r in world.relations_of(o.id) if r.pred == "isolated_from"), None)
        apart = f", {isolated:.0f} m from anyone" if isolated is not None else ""
        label = f"{o.id}: still {o.stationary_s:.1f} s{apart}, conf {o.conf:.2f}"
    if not (casualty or show_label):
        return
    right = x > 0.6 * frame.spec.width_px  # keep long labels inside the picture
    ax.text(  # type: ignore[attr-defined]
        x + (box.width if right and box is not None else 0.0),
        max(y - 4, 4 * font),
        label,
        color=color,
        fontsize=font * (1.2 if casualty else 0.8),
        va="bottom",
        ha="right" if right else "left",
        fontweight="bold" if casualty else "normal",
        bbox={"facecolor": "black", "alpha": 0.5, "pad": 1, "edgecolor": "none"} if casualty else None,
    )


def _scale_bar(ax: object, frame: Frame, scale: float, font: float) -> None:
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
    ax.add_patch(Rectangle((x0, y0), length_px, thick, facecolor="white", edgecolor="black"))  # type: ignore[attr-defined]
    text = f"{length_m:g} m"
    ax.text(x0 + length_px / 2, y0 - 4, text, color="white", fontsize=font, ha="center", va="bottom")  # type: ignore[attr-defined]
