"""Our person detector, shipped as package data: ``weights/person.onnx`` (trained here on rendered frames,
``python -m evaluation.detector.train``) and ``weights/person.json``, its recipe (data seed, sizes, epochs, the
file's SHA-256, the calibration and the operating threshold). :func:`load_ours` checks the SHA-256 before it runs
anything, so a damaged or swapped file is refused.

>>> recipe = read_recipe()
>>> sorted(k for k in ("sha256", "calibration", "score_threshold") if k in recipe)
['calibration', 'score_threshold', 'sha256']
"""

from __future__ import annotations

import hashlib
import json
from importlib import resources
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from ...contracts.errors import InputError, field_problem
from ..calibration import Calibration
from .onnx import OnnxDetector
from .rescue import Rescue
from .second_look import SecondLook

WEIGHTS = "person.onnx"
RECIPE = "person.json"
MAX_DETECTIONS = 2000
"""Detections kept a frame: a crowd seen from 60 m holds up to about 1,400 persons, and YOLO's customary 300 would
silently drop the rest (at 30 m it cost a third of the persons found)."""


def weights_dir() -> Path:
    """The folder of the shipped weights (inside the installed package)."""
    return Path(str(resources.files("agentic_core.perception.detectors") / "weights"))


def read_recipe(folder: Path | None = None) -> dict[str, Any]:
    """The recipe beside the weights; :class:`InputError` naming it when it is missing or not JSON."""
    path = (folder or weights_dir()) / RECIPE
    try:
        recipe = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"{path}: the detector's recipe is missing (reinstall agentic-uavs)") from None
    except (OSError, ValueError) as exc:
        raise InputError(f"{path}: the detector's recipe cannot be read ({exc})") from None
    if not isinstance(recipe, dict) or not isinstance(recipe.get("sha256"), str):
        raise InputError(f"{path}: the detector's recipe has no sha256")
    return recipe


def load_ours(folder: Path | None = None, *, threads: int = 1) -> OnnxDetector:
    """The shipped person detector, its confidence calibrated and its threshold the recipe's; the weights' SHA-256
    must be the recipe's (:class:`InputError` naming both otherwise)."""
    root = folder or weights_dir()
    recipe = read_recipe(root)
    path = root / WEIGHTS
    try:
        digest = hashlib.sha256(path.read_bytes()).hexdigest()
    except FileNotFoundError:
        raise InputError(f"{path}: the shipped detector's weights are missing (reinstall agentic-uavs)") from None
    if digest != recipe["sha256"]:
        raise InputError(
            f"{path}: SHA-256 {digest} is not the recipe's {recipe['sha256']} ({root / RECIPE}): the weights were "
            "changed or damaged; reinstall agentic-uavs or retrain (python -m evaluation.detector.train)"
        )
    try:
        calibration = Calibration.model_validate(recipe["calibration"]) if recipe.get("calibration") else None
    except ValidationError as exc:
        raise InputError(f"{root / RECIPE}: {field_problem(exc, 'calibration')}") from None
    rescue, second_look = passes(recipe, root / RECIPE)
    return OnnxDetector(
        path,
        layout="v8",
        class_names=["person"],
        score_threshold=float(recipe.get("score_threshold", 0.25)),
        calibration=calibration,
        threads=threads,
        max_detections=MAX_DETECTIONS,
        rescue=rescue,
        second_look=second_look,
    )


def passes(recipe: dict[str, Any], where: Path) -> tuple[Rescue | None, SecondLook | None]:
    """How a recipe runs its model beyond one plain pass: the rescue of crowded persons and the second look at
    close frames, each None when the recipe has none; :class:`InputError` naming ``where`` when one is wrong."""
    rescue = Rescue.from_recipe(recipe["rescue"], where) if recipe.get("rescue") is not None else None
    look = SecondLook.from_recipe(recipe["second_look"], where) if recipe.get("second_look") is not None else None
    return rescue, look


__all__ = ["MAX_DETECTIONS", "RECIPE", "WEIGHTS", "load_ours", "passes", "read_recipe", "weights_dir"]
