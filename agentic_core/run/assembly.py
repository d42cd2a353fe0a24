"""What a run is assembled from, loaded with clear errors: the mission, the scene, an empty world for a run with
no scene; and ``setup_frozen``, which keeps the set-up out of the garbage collector's passes while it flies."""

from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from flight.sim.scene_file import load_scene
from flight.sim.scene_model import Scene
from tools import ToolRegistry

from ..mission.model import PolicyGraph
from ..mission.validate import load_mission
from ..perception.world_model import WorldModel
from .settings import RunError


class NoWorld:
    """The world source of a run without a scene: an empty World Model."""

    @property
    def world(self) -> WorldModel:
        return WorldModel.model_validate(
            {"timestamp": 0.0, "ego_pose": {"north": 0, "east": 0, "down": 0, "lat": 0, "lon": 0, "alt": 0}}
        )

    def target(self, object_id: str) -> tuple[float, float] | None:
        return None

    def resolve(self, object_id: str) -> str | None:
        return None


def load_run_mission(path: Path, registry: ToolRegistry, home: tuple[float, float] | None = None) -> PolicyGraph:
    from ..mission.source import MissionError

    try:
        return load_mission(path, tools=registry, home=home)
    except MissionError as exc:
        raise RunError(str(exc)) from None


def load_run_scene(path: Path) -> Scene:
    from flight.sim.scene_file import SceneFileError

    try:
        return load_scene(path)
    except SceneFileError as exc:
        raise RunError(str(exc)) from None


@contextmanager
def setup_frozen() -> Iterator[None]:
    """Leave everything that exists now (a run's set-up: the scene, the vehicle, the compiled mission, the models)
    out of the garbage collector's passes until the block ends (``gc.freeze``; undone at the end)."""
    gc.collect()
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


__all__ = ["NoWorld", "load_run_mission", "load_run_scene", "setup_frozen"]
