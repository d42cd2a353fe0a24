"""Labels that do not overlap: each label goes to the best of 24 spots around its point — never on a label placed
before it nor on a marker, over as little of the flown track as can be, as close as it can (with a leader line when
further out); a label with no such spot is left out rather than printed over another (unless it must be shown).

Why: a plot over a scene names many things close together (tents along a road, a casualty beside a shade), and
matplotlib draws text where it is told, over whatever is there.

>>> from matplotlib.backends.backend_agg import FigureCanvasAgg
>>> from matplotlib.figure import Figure
>>> fig = Figure(figsize=(3, 3)); _ = FigureCanvasAgg(fig); ax = fig.add_subplot()
>>> _ = ax.set_xlim(0, 10); _ = ax.set_ylim(0, 10)
>>> placer = LabelPlacer(ax)
>>> shown = [placer.place(5, 5, "Tent-1"), placer.place(5, 5, "Tent-2")]
>>> [t is not None for t in shown], placer.overlaps()
([True, True], 0)
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from matplotlib.axes import Axes
from matplotlib.text import Annotation, Text
from matplotlib.transforms import Bbox

OFFSETS_PT: tuple[tuple[float, float], ...] = tuple(
    (dx * r, dy * r)
    for r in (1.0, 2.2, 3.6)
    for dx, dy in ((1, 1), (1, -1), (-1, 1), (-1, -1), (1.3, 0), (-1.3, 0), (0, 1.3), (0, -1.3))
)
"""Where a label may go, in units of :data:`BASE_PT` from its anchor: the eight directions at three distances."""
BASE_PT = 5.0
RING_COST = 0.5
"""What moving a label one ring further out costs, in track points under it (0.1 each)."""
MARKER_PT = 5.0
"""Half the size of the box kept clear around each marker."""


class LabelPlacer:
    """Places labels on ``ax`` one by one (most important first); call it once the axes' limits and the figure's
    layout are final, since it measures the texts where they will be drawn."""

    def __init__(self, ax: Axes) -> None:
        self.ax = ax
        self.renderer = ax.figure.canvas.get_renderer()  # type: ignore[attr-defined]
        self.placed: list[Bbox] = []
        self.texts: list[str] = []
        """The labels shown, in the order placed."""
        self.markers: list[Bbox] = []
        self.track: list[tuple[float, float]] = []
        self._area = ax.get_window_extent(self.renderer)

    def avoid_markers(self, points: Iterable[tuple[float, float]]) -> None:
        """Keep labels off these data points (the markers drawn there)."""
        half = MARKER_PT * self.ax.figure.dpi / 72.0
        for x, y in points:
            px, py = self.ax.transData.transform((x, y))
            self.markers.append(Bbox.from_extents(px - half, py - half, px + half, py + half))

    def avoid_track(self, points: Iterable[tuple[float, float]]) -> None:
        """Keep labels off the flown track where they can (points in data coordinates)."""
        self.track.extend((float(x), float(y)) for x, y in self.ax.transData.transform(list(points)))

    def place(self, x: float, y: float, text: str, *, must: bool = False, **style: Any) -> Annotation | None:
        """The label ``text`` for the point (x, y), at its best free spot; None when there is none and not ``must``.

        A spot further out costs as much as a few track points under a nearer one, so a label stays by its point
        unless that would hide more of the track."""
        best: tuple[float, float, Annotation] | None = None
        for i, (dx, dy) in enumerate(OFFSETS_PT):
            ring = i // 8
            label = self.ax.annotate(
                text, (x, y), xytext=(dx * BASE_PT, dy * BASE_PT),
                textcoords="offset points", ha="left" if dx > 0 else "right" if dx < 0 else "center",
                va="bottom" if dy > 0 else "top" if dy < 0 else "center",
                arrowprops={"arrowstyle": "-", "color": "#868e96", "linewidth": 0.6, "shrinkA": 1, "shrinkB": 4}
                if ring else None, **style,
            )  # fmt: skip
            cost = self._cost(self._box(label))
            score = cost + RING_COST * ring
            if best is None or score < best[0]:
                if best is not None:
                    best[2].remove()
                best = (score, cost, label)
            else:
                label.remove()
            if score == 0.0:
                break
        assert best is not None
        _, cost, label = best
        if must or cost < 1e3:  # at worst some track under it: still readable
            self._keep(label)
            return label
        label.remove()
        return None

    def _keep(self, label: Annotation) -> None:
        self.placed.append(self._box(label))
        self.texts.append(label.get_text())

    def _box(self, label: Annotation) -> Bbox:
        """Where the label's text is on the canvas (without its leader line)."""
        label.update_positions(self.renderer)
        return Text.get_window_extent(label, self.renderer)

    def _cost(self, box: Bbox) -> float:
        """0 for a free spot; 1 per track point under it; far more for a label, a marker or the axes' edge."""
        if not self._inside(box):
            return 1e6
        hits = sum(bool(box.overlaps(other)) for other in self.placed) * 1e4
        hits += sum(bool(box.overlaps(other)) for other in self.markers) * 1e3
        hits += sum(box.x0 <= px <= box.x1 and box.y0 <= py <= box.y1 for px, py in self.track) * 0.1
        return float(hits)

    def _inside(self, box: Bbox) -> bool:
        area = self._area
        return bool(box.x0 >= area.x0 and box.x1 <= area.x1 and box.y0 >= area.y0 and box.y1 <= area.y1)

    def overlaps(self) -> int:
        """How many pairs of placed labels overlap (0, unless some had to be shown)."""
        boxes = self.placed
        return sum(bool(a.overlaps(b)) for i, a in enumerate(boxes) for b in boxes[i + 1 :])


__all__ = ["LabelPlacer"]
