"""Scene files: YAML (or JSON) in, a checked :class:`~flight.sim.scene_model.Scene` out, every problem at its line.

A wrong scene file raises :class:`SceneFileError`, whose message lists each problem as ``file:line:col: message``
with the field's path (``scenes/x.yaml:14:17: actors[3] (P-S2).behaviour: ...``): YAML syntax, duplicate keys,
wrong types, unknown fields (with the nearest known name), and the scene checks (unknown ids, a casualty who is not
isolated, a wrong person count). Positions come from PyYAML's composed node tree, looked up by the field's path
with :mod:`flight.yaml_positions`, which the mission loader (``agentic_core.mission.source``) uses too.

The JSON Schema of scene files (:func:`scene_json_schema`) ships as ``scenes/scene.schema.json``; regenerate it
with ``agentic-uav schema scene > scenes/scene.schema.json``.

>>> scene = load_scene("scenes/hajj_normal.yaml")
>>> scene.id, scene.ground_truth.expected_severity, scene.persons == scene.ground_truth.persons
('hajj-normal', 'none', True)
>>> load_scene("actors:\\n  - {id: P-1, position: {north: 0, east: 0}, behaviour: lying}\\n", file="bad.yaml")
Traceback (most recent call last):
...
flight.sim.scene_file.SceneFileError: bad.yaml:1:1: missing required field 'id'
bad.yaml:2:57: actors[0] (P-1).behaviour: Input should be 'walking', 'running', ... or 'parked' (got 'lying')
"""

from __future__ import annotations

import difflib
import os
import types
import typing
from pathlib import Path as FilePath
from typing import Any

import yaml
from pydantic import BaseModel, ValidationError

from agentic_core.contracts.input_files import InputFileError, check_input_file
from agentic_core.contracts.problems import LocatedProblem, ProblemsError
from agentic_core.contracts.yaml_positions import KeyIndex, node_position, position_at
from flight.sim.scene_model import Path, Scene, describe_path, scene_problems

_Loader: type[yaml.SafeLoader] = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
SCHEMA_HEADER = "# yaml-language-server: $schema=scene.schema.json\n"


SceneProblem = LocatedProblem
"""One thing wrong with a scene file: ``file:line:col: message`` (1-based line and column)."""


class SceneFileError(ProblemsError):
    """A scene file that cannot be used; ``problems`` lists everything found wrong, in file order."""


def load_scene(source: str | os.PathLike[str], *, file: str | None = None) -> Scene:
    """A scene from a file path, or from YAML/JSON text (then ``file`` names it in messages).

    Raises :class:`SceneFileError` naming the file, line and field of every problem; never anything else for
    bad input.
    """
    text_given = isinstance(source, str) and ("\n" in source or not source.endswith((".yaml", ".yml", ".json")))
    if text_given:
        return _parse(str(source), file or "<scene>")
    path = FilePath(source)
    name = file or str(source)
    try:
        check_input_file(path, "scene")
        raw = path.read_bytes()
    except InputFileError as exc:
        raise SceneFileError([SceneProblem(name, 1, 1, exc.reason)]) from None
    except OSError as exc:
        raise SceneFileError([SceneProblem(name, 1, 1, f"cannot read the file: {exc.strerror or exc}")]) from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        col = exc.start - (raw.rfind(b"\n", 0, exc.start) + 1) + 1
        message = f"not UTF-8 text: byte 0x{raw[exc.start]:02x} cannot be read; save the file as UTF-8"
        raise SceneFileError([SceneProblem(name, line, col, message)]) from None
    return _parse(text, name)


def dump_scene(scene: Scene) -> str:
    """A scene as YAML that :func:`load_scene` reads back equal (defaults left out)."""
    data = scene.model_dump(mode="json", by_alias=True, exclude_defaults=True)
    data = {"id": scene.id, **data}  # the id first, and always there
    return SCHEMA_HEADER + yaml.safe_dump(data, sort_keys=False, allow_unicode=True, width=120)


def save_scene(scene: Scene, path: str | os.PathLike[str]) -> None:
    FilePath(path).write_text(dump_scene(scene), encoding="utf-8")


def scene_json_schema() -> dict[str, Any]:
    """The JSON Schema of scene files, generated from :class:`~flight.sim.scene_model.Scene`."""
    schema = Scene.model_json_schema(by_alias=True)
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "agentic-uavs scene"
    return schema


def _parse(text: str, file: str) -> Scene:
    loader = _Loader(text)
    try:
        root = loader.get_single_node()
        if root is not None:
            problems = _duplicate_keys(root, file)
            data = loader.construct_document(root)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line, col = (mark.line + 1, mark.column + 1) if mark else (1, 1)
        raise SceneFileError([SceneProblem(file, line, col, f"YAML syntax error: {exc.problem or exc}")]) from None
    except yaml.reader.ReaderError as exc:
        before = text[: exc.position]
        line, col = before.count("\n") + 1, exc.position - (before.rfind("\n") + 1) + 1
        raise SceneFileError([SceneProblem(file, line, col, "YAML cannot contain this character")]) from None
    except SceneFileError:
        raise
    except (yaml.YAMLError, RecursionError, ValueError) as exc:
        raise SceneFileError([SceneProblem(file, 1, 1, f"YAML error: {exc}")]) from None
    finally:
        loader.dispose()
    if root is None:
        raise SceneFileError([SceneProblem(file, 1, 1, "the file is empty; a scene needs at least an id")])
    if not isinstance(data, dict):
        kind = type(data).__name__
        raise SceneFileError([*problems, SceneProblem(file, 1, 1, f"a scene is a mapping with an id, not a {kind}")])
    try:
        scene = Scene.model_validate(data, context={"defer_checks": True})
    except ValidationError as exc:
        raise SceneFileError([*problems, *_schema_problems(exc, data, root, file)]) from None
    index: KeyIndex = {}  # each mapping's keys looked up once, however many problems it holds
    for path, message in scene_problems(scene):
        mix_key = isinstance(path[-1], str) and path[-2:-1] == ("mix",)
        line, col = position_at(root, path, key=mix_key, index=index)
        problems.append(SceneProblem(file, line, col, f"{describe_path(path, data)}: {message}"))
    if problems:
        raise SceneFileError(problems)
    return scene


def _schema_problems(exc: ValidationError, data: Any, root: yaml.Node, file: str) -> list[SceneProblem]:
    out: list[SceneProblem] = []
    index: KeyIndex = {}  # each mapping's keys looked up once, however many problems it holds
    for err in exc.errors():
        loc = tuple(err["loc"])
        if loc and loc[-1] == "[key]":
            path: Path = loc[:-1]
            line, col = position_at(root, path, key=True, index=index)
            message = f"{describe_path(path, data)}: {err['msg']} (got {_short(path[-1])})"
        elif err["type"] == "missing":
            path = loc
            line, col = position_at(root, path[:-1], index=index)
            message = f"{describe_path(path[:-1], data)}: " if len(path) > 1 else ""
            message += f"missing required field {path[-1]!r}"
        elif err["type"] == "extra_forbidden":
            path = loc
            line, col = position_at(root, path, key=True, index=index)
            known = _fields_at(path[:-1])
            close = difflib.get_close_matches(str(path[-1]), known, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else f"; known fields: {', '.join(known)}"
            where = describe_path(path[:-1], data) if len(path) > 1 else "the scene"
            message = f"{where}: unknown field {path[-1]!r}{hint}"
        else:
            path = loc
            line, col = position_at(root, path, index=index)
            message = f"{describe_path(path, data)}: {err['msg']} (got {_short(err['input'])})"
        out.append(SceneProblem(file, line, col, message))
    return out


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _duplicate_keys(node: yaml.Node, file: str) -> list[SceneProblem]:
    """Every duplicate mapping key (a node an alias shares is looked at once); a :class:`SceneFileError` for a node
    that contains itself (an alias inside its own anchor), whose document would be infinite."""
    out: list[SceneProblem] = []
    done: set[int] = set()
    inside: set[int] = set()  # the nodes on the way from the root to the one at hand
    stack: list[tuple[yaml.Node, bool]] = [(node, False)]
    while stack:
        n, leaving = stack.pop()
        if leaving:
            inside.discard(id(n))
            done.add(id(n))
            continue
        if id(n) in inside:
            line, col = node_position(n)
            message = "a YAML alias refers to itself: the document would be infinite"
            raise SceneFileError([SceneProblem(file, line, col, message)])
        if id(n) in done or not isinstance(n, yaml.MappingNode | yaml.SequenceNode):
            continue
        inside.add(id(n))
        stack.append((n, True))
        if isinstance(n, yaml.MappingNode):
            seen: dict[str, int] = {}
            for k, v in n.value:
                if isinstance(k, yaml.ScalarNode):
                    if k.value in seen:
                        message = f"duplicate key {k.value!r} (first at line {seen[k.value]})"
                        out.append(SceneProblem(file, *node_position(k), message))
                    seen.setdefault(k.value, k.start_mark.line + 1)
                stack.append((v, False))
        else:
            stack.extend((item, False) for item in n.value)
    return out


def _fields_at(path: Path) -> list[str]:
    """The field names (aliases as written in files) of the model at ``path`` in a scene."""
    model: Any = Scene
    for part in path:
        if isinstance(part, int):
            continue
        fields = {(f.alias or name): f for name, f in model.model_fields.items()}
        field = fields.get(str(part))
        model = _model_in(field.annotation) if field is not None else None
        if model is None:
            return []
    return sorted((f.alias or name) for name, f in model.model_fields.items())


def _model_in(annotation: Any) -> type[BaseModel] | None:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    if isinstance(annotation, types.UnionType) or typing.get_origin(annotation) in (list, typing.Union):
        for arg in typing.get_args(annotation):
            found = _model_in(arg)
            if found is not None:
                return found
    return None
