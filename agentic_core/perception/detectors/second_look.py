"""A second look at a close frame: the detector run twice on the frame shifted by half a grid cell, the two passes'
boxes merged, so that where a person falls on the model's grid does not decide whether they are seen.

Why: a centre-point model with a stride-4 grid scores one person differently as their centre moves within a cell.
Our detector's score for a lone person lying 15.8 m below swings between 0.22 and 0.56 as the view moves by 0.2 m
(one cell), and a drone hovering still for a close look sees one view. From 144 hover positions within a metre of
where the emergency mission hovers over its collapsed pilgrim, one pass a frame left the World Model's confidence
in them under the 0.5 its confirmation asks for at 14 (12 with no track at all) after 1.6 s. Two passes, the second
shifted by half a cell diagonally, and alternating frame by frame with the other diagonal (right, then down), so
that two frames in a row see all four phases of the cell: none under 0.5, the lowest 0.58
(``tests/agentic_core/perception/detectors/test_second_look.py`` tries 25 of them). A person found by either pass
is kept at the better of the two scores (NMS over both). It doubles the detector's time, so it runs only on close
frames: those where a person ``person_m`` long would span at least ``from_person_px`` pixels, which the camera's
focal length and height tell before anything is detected. The shipped detector's calibration and threshold are
fitted on what this gives (:mod:`evaluation.detector.report`).

>>> look = SecondLook(shift_px=2, from_person_px=24.0)
>>> look.wanted(focal_px=355.4, height_m=15.8), look.wanted(focal_px=355.4, height_m=30.0)
(True, False)
>>> SecondLook.from_recipe({"shift_px": 0}, Path("person.json"))
Traceback (most recent call last):
...
agentic_core.contracts.errors.InputError: person.json: second_look.shift_px: Input should be greater than or equal to 1
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from ...contracts.errors import InputError, field_problem
from .suppression import nms

FloatArray = NDArray[np.float32]
Pass = tuple[FloatArray, FloatArray, list[str]]
"""One pass of a detector over an image: boxes (K×4, frame pixels), raw scores, class names."""


class SecondLook(BaseModel):
    """When to look twice and how far to shift (a recipe's ``second_look`` entry)."""

    model_config = ConfigDict(frozen=True, extra="forbid", strict=True, allow_inf_nan=False)

    shift_px: int = Field(default=2, ge=1, le=16, description="the shift of the second pass: half the model's stride")
    from_person_px: float = Field(
        default=24.0, ge=1.0, le=4096.0, description="look twice when a person_m person would span this many pixels"
    )
    person_m: float = Field(default=1.7, ge=0.3, le=5.0, description="the length of a person, lying")

    @classmethod
    def from_recipe(cls, entry: Any, where: Path) -> SecondLook:
        """The recipe's ``second_look`` entry; :class:`InputError` naming the recipe and the field when one is
        wrong."""
        try:
            return cls.model_validate(entry)
        except ValidationError as exc:
            raise InputError(f"{where}: {field_problem(exc, 'second_look')}") from None

    def wanted(self, focal_px: float, height_m: float) -> bool:
        """Whether a frame from a camera of ``focal_px`` at ``height_m`` above the ground is close enough; a camera
        at or under the ground (a height that is not positive) is as close as can be."""
        if not height_m > 0.0:
            return True
        return self.person_m * focal_px / height_m >= self.from_person_px

    def shifts(self, index: int) -> tuple[tuple[int, int], tuple[int, int]]:
        """The (right, down) shifts of frame ``index``'s two passes: none and both on even frames, right and down on
        odd ones, so that two frames in a row see the cell's four phases."""
        s = self.shift_px
        return ((0, 0), (s, s)) if index % 2 == 0 else ((s, 0), (0, s))

    def look(
        self,
        detect: Callable[[NDArray[np.uint8]], Pass],
        image: NDArray[np.uint8],
        *,
        index: int,
        iou: float,
        max_keep: int,
    ) -> Pass:
        """``detect`` on ``image`` shifted by each of frame ``index``'s :meth:`shifts`, the boxes moved back into the
        frame's pixels and the passes merged by NMS at ``iou`` per class (at most ``max_keep``): each person at the
        better of their two scores."""
        height, width = image.shape[:2]
        all_boxes, all_scores, all_labels = [], [], []
        for right, down in self.shifts(index):
            boxes, scores, labels = detect(shifted(image, right, down))
            boxes = boxes.reshape(-1, 4)
            back = boxes - np.array([right, down, right, down], np.float32)
            back[boxes[:, 2] >= width - 0.5, 2] = width  # cut by the edge: the frame's last columns are not in view
            back[boxes[:, 3] >= height - 0.5, 3] = height
            np.clip(back[:, 0::2], 0, width, out=back[:, 0::2])
            np.clip(back[:, 1::2], 0, height, out=back[:, 1::2])
            seen = (back[:, 2] > back[:, 0]) & (back[:, 3] > back[:, 1])  # not a box of the repeated edge alone
            all_boxes.append(back[seen])
            all_scores.append(np.asarray(scores, np.float32)[seen])
            all_labels += [label for label, keep in zip(labels, seen.tolist(), strict=True) if keep]
        merged_boxes, merged_scores = np.concatenate(all_boxes).astype(np.float32), np.concatenate(all_scores)
        names = sorted(set(all_labels))
        classes = np.array([names.index(n) for n in all_labels], np.int64)
        kept = nms(merged_boxes, merged_scores, iou, classes, max_keep)
        return merged_boxes[kept], merged_scores[kept], [all_labels[k] for k in kept]


def shifted(image: NDArray[np.uint8], right: int, down: int) -> NDArray[np.uint8]:
    """``image`` moved ``right`` and ``down`` pixels, its first columns and rows repeated into the gap."""
    if not (right or down):
        return image
    height, width = image.shape[:2]
    padded = np.pad(image, ((down, 0), (right, 0), (0, 0)), mode="edge")
    return np.ascontiguousarray(padded[:height, :width])


__all__ = ["Pass", "SecondLook", "shifted"]
