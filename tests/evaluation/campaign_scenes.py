"""Small generated scenes written to files, for the campaign tests (two scenes: the second has a casualty)."""

from __future__ import annotations

from pathlib import Path

from flight.sim.scene_file import dump_scene
from flight.sim.scene_gen import generate_scene


def write_scenes(folder: Path, *, first_seed: int, persons: int, prefix: str, count: int = 2) -> list[str]:
    """``count`` scenes ``{prefix}-1.yaml``… in ``folder``, their paths: every second one has a casualty, each one
    distractor."""
    paths = []
    for i in range(count):
        name = f"{prefix}-{i + 1}"
        scene = generate_scene(first_seed + i, persons=persons, casualties=i % 2, distractors=1, scene_id=name)
        path = folder / f"{prefix}-{i + 1}.yaml"
        path.write_text(dump_scene(scene), encoding="utf-8")
        paths.append(str(path))
    return paths
