"""The shipped example missions and scenes, as package data: find one by name, list them, copy them out to edit.

They live in ``agentic_core/examples/missions`` and ``agentic_core/examples/scenes`` of the installed package (in
a checkout those two are links to the repository's ``missions/`` and ``scenes/``), side by side, so a shipped
mission finds its scene as a mission file does: ``scenes/<mission name>.yaml`` beside its folder.

>>> path = mission_path("hajj_emergency")
>>> path.name, path.parent.name
('hajj_emergency.yaml', 'missions')
>>> resolve_mission(Path("hajj_emergency")) == path  # a bare name with no such file here
True
>>> [m.name for m in shipped_missions()][:2]
['hajj_emergency', 'hajj_patrol']
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib.resources import files
from importlib.resources.abc import Traversable
from pathlib import Path

import yaml

from ..contracts.errors import InputError

KINDS = ("missions", "scenes")
"""The two folders of shipped examples (and of a copy of them)."""


class ExampleError(InputError):
    """A shipped example that does not exist, or a copy that would overwrite files or cannot be written."""


@dataclass(frozen=True)
class Example:
    """One shipped file: its name (the file's stem), where it is, what it is about and, for a mission, its scene."""

    name: str
    path: Path
    summary: str
    scene: str | None = None


def examples_root() -> Path:
    """The shipped examples' folder on disk (an installed wheel or a checkout; a zipped package has none)."""
    root: Traversable = files(__name__)
    if not isinstance(root, Path):
        raise ExampleError(f"the shipped examples are not on disk ({root}); install agentic-uavs unzipped")
    return root


def _files(kind: str) -> list[Path]:
    """The shipped files of ``kind``, sub-folders included (the trap missions live in ``missions/examples``)."""
    root = examples_root() / kind
    found = [p for p in root.rglob("*") if p.suffix in (".yaml", ".json") and p.is_file()]
    return sorted(found, key=lambda p: (len(p.relative_to(root).parts), p.name))  # the top folder's first


def _summary(path: Path, field: str) -> str:
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, yaml.YAMLError):
        return ""
    value = data.get(field, "") if isinstance(data, dict) else ""
    return " ".join(str(value).split())


def shipped_missions() -> list[Example]:
    """The shipped missions, by name, each with its goal and the shipped scene of the same name if there is one."""
    scenes = {s.name for s in shipped_scenes()}
    return [
        Example(p.stem, p, _summary(p, "goal"), p.stem if p.stem in scenes else None)
        for p in _files("missions")
        if p.suffix == ".yaml"
    ]


def shipped_scenes() -> list[Example]:
    """The shipped simulated scenes, by name, each with its description."""
    return [Example(p.stem, p, _summary(p, "description")) for p in _files("scenes") if p.suffix == ".yaml"]


def _shipped(kind: str, name: str, examples: list[Example]) -> Path:
    for example in examples:
        if example.name == name:
            return example.path
    names = ", ".join(e.name for e in examples)
    singular = kind.removesuffix("s")
    raise ExampleError(
        f"{name}: no such {singular} file, and no shipped {singular} of that name (shipped: {names}; "
        "see agentic-uav examples)"
    )


def mission_path(name: str) -> Path:
    """The file of the shipped mission ``name``; :class:`ExampleError` listing the shipped ones if there is none."""
    return _shipped("missions", name, shipped_missions())


def scene_path(name: str) -> Path:
    """The file of the shipped scene ``name``; :class:`ExampleError` listing the shipped ones if there is none."""
    return _shipped("scenes", name, shipped_scenes())


def _bare(given: Path) -> bool:
    """A name, not a path: one part, no suffix, and no such file here."""
    return len(given.parts) == 1 and not given.suffix and not given.exists()


def resolve_mission(given: Path) -> Path:
    """``given`` itself when it is a path (the loader reports a missing file), else the shipped mission of that
    name; a file of that name in the working directory wins over a shipped one."""
    return mission_path(str(given)) if _bare(given) else given


def resolve_scene(given: Path) -> Path:
    """An existing scene file as given, else the shipped scene of that name; :class:`ExampleError` otherwise."""
    if _bare(given):
        return scene_path(str(given))
    if not given.is_file():
        raise ExampleError(f"{given}: no such scene file")
    return given


def copy_examples(dest: Path, *, force: bool = False) -> list[Path]:
    """Write the shipped missions and scenes (with their JSON Schemas) to ``dest/missions`` and ``dest/scenes``,
    laid out as shipped so a copied mission still finds its scene; the files written.

    Nothing is written when one of them exists already, unless ``force``: the error names every such file.
    """
    plan = [
        (source, dest / kind / source.relative_to(examples_root() / kind)) for kind in KINDS for source in _files(kind)
    ]
    for folder in [dest, *(dest / kind for kind in KINDS)]:
        if folder.exists() and not folder.is_dir():
            raise ExampleError(f"{folder}: exists and is not a folder")
    existing = [str(target) for _, target in plan if target.exists()]
    if existing and not force:
        raise ExampleError(f"{', '.join(existing)}: already there; nothing was copied (--force overwrites)")
    try:
        for source, target in plan:
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(source.read_bytes())
    except OSError as exc:
        raise ExampleError(f"{exc.filename or dest}: cannot write: {exc.strerror or exc}") from None
    return [target for _, target in plan]


__all__ = [
    "KINDS",
    "Example",
    "ExampleError",
    "copy_examples",
    "examples_root",
    "mission_path",
    "resolve_mission",
    "resolve_scene",
    "scene_path",
    "shipped_missions",
    "shipped_scenes",
]
