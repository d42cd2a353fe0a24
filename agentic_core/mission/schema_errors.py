"""Schema errors as a person reads them: each pydantic error of a mission, mapped back to the document path of
the offending value (and so to its line and column), grouped by value, and worded for the mission's author.

A value that may be a number or a ``${...}`` template gets one message, not one per union member; an unknown
action or field gets a did-you-mean; a missing field is reported at its parent.
"""

from __future__ import annotations

import difflib
import re
import types
import typing
from collections.abc import Iterable
from typing import Any

from pydantic import BaseModel, ValidationError

from agentic_core.contracts import action_args, mission_limits, mission_steps, mission_values, policy_graph

from .model import ACTIONS, STEP_MODELS, PolicyGraph
from .source import Path, Problem, SourceMap


def suggest(word: str, choices: Iterable[str]) -> str:
    """A did-you-mean hint for the closest of ``choices`` (``" (did you mean 'x'?)"``), or ``""``."""
    match = difflib.get_close_matches(word, list(choices), n=1)
    return f" (did you mean {match[0]!r}?)" if match else ""


_SCALAR_TAGS = frozenset({"str", "int", "float", "bool", "none"})


def _union_tag(part: Any) -> bool:
    """Whether a part of a pydantic location names a union member (``Circle``, ``list[LatLon]``, ``str``), not a
    field: mission fields are snake_case names."""
    return (
        isinstance(part, str)
        and part != "[key]"
        and (part[:1].isupper() or "[" in part or "-" in part or part in _SCALAR_TAGS)
    )


def _data_path(data: Any, loc: tuple[int | str, ...]) -> Path:
    """Turn a pydantic error location into a document path, skipping union tags and resolving aliases."""
    path: list[str | int] = []
    node = data
    tag_seen: Any = None
    for part in loc:
        if isinstance(node, dict) and part == node.get("action") and part in ACTIONS and tag_seen is not node:
            tag_seen = node  # the discriminator's tag (once: a step may also have a key of that name)
            continue
        if isinstance(node, list) and isinstance(part, int) and part < len(node):  # noqa: SIM114 - apart, so mypy narrows each
            path.append(part)
            node = node[part]
        elif isinstance(node, dict) and part in node:
            path.append(part)
            node = node[part]
        elif isinstance(node, dict) and isinstance(part, str) and part.rstrip("_") in node:
            path.append(part.rstrip("_"))  # if_ / else_ are written if / else
            node = node[part.rstrip("_")]
        elif _union_tag(part):
            continue
        elif isinstance(part, str) and isinstance(node, dict) and part not in ACTIONS and part != "[key]":
            path.append(part)  # a missing field: its parent's position is used
            break
    return tuple(path)


def _branch(data: Any, loc: tuple[int | str, ...]) -> tuple[tuple[int | str, ...], bool | None] | None:
    """The first union member in ``loc`` whose value is a list or a mapping: the location up to it, and whether
    the member has the value's shape (a list member for a list, a model for a mapping; None: neither)."""
    node = data
    for i, part in enumerate(loc):
        if _union_tag(part):
            wants_list, wants_map = str(part).startswith("list["), str(part)[:1].isupper()
            if isinstance(node, dict | list) and (wants_list or wants_map):
                return loc[:i], wants_list == isinstance(node, list)
            continue
        if isinstance(node, list) and isinstance(part, int) and part < len(node):  # noqa: SIM114 - apart, so mypy narrows each
            node = node[part]
        elif isinstance(node, dict) and part in node:
            node = node[part]
        elif isinstance(node, dict) and isinstance(part, str) and part.rstrip("_") in node:
            node = node[part.rstrip("_")]
        else:
            return None
    return None


def _of_the_meant_member(data: Any, errors: list[Any]) -> list[Any]:
    """The errors less those of a union member of another shape than the value (a list member's for a mapping)
    where a member of the value's shape is there to say what is wrong: the author meant that one."""
    branches = [_branch(data, tuple(e["loc"])) for e in errors]
    meant = {b[0] for b in branches if b is not None and b[1]}
    kept = [e for e, b in zip(errors, branches, strict=True) if b is None or b[1] or b[0] not in meant]
    return kept or errors


def _model_at(data: Any, path: Path) -> type[BaseModel] | None:
    """The mission model that the mapping at ``path`` is validated as (for did-you-mean on unknown fields)."""
    ann: Any = PolicyGraph
    node: Any = data
    for part in path:
        ann = _narrow(ann, node)
        if isinstance(part, int):
            ann = _narrow(typing.get_args(ann)[0] if typing.get_args(ann) else Any, None)
            node = node[part] if isinstance(node, list) and part < len(node) else None
            continue
        if not (isinstance(ann, type) and issubclass(ann, BaseModel)):
            return None
        fields = {f.alias or name: f for name, f in ann.model_fields.items()}
        if part not in fields:
            return None
        ann = fields[part].annotation
        node = node.get(part) if isinstance(node, dict) else None
    ann = _narrow(ann, node)
    return ann if isinstance(ann, type) and issubclass(ann, BaseModel) else None


def _narrow(ann: Any, node: Any) -> Any:
    """Unwrap Annotated/Optional/unions to what ``node`` is: a step by its action, a model for a mapping."""
    while typing.get_origin(ann) is typing.Annotated:
        ann = typing.get_args(ann)[0]
    members = typing.get_args(ann) if typing.get_origin(ann) in (typing.Union, types.UnionType) else (ann,)
    action = node.get("action") if isinstance(node, dict) else None
    if isinstance(action, str) and action in STEP_MODELS:
        return STEP_MODELS[action]
    for member in members:
        while typing.get_origin(member) is typing.Annotated:
            member = typing.get_args(member)[0]
        if isinstance(node, dict) and isinstance(member, type) and issubclass(member, BaseModel):
            return member
        if isinstance(node, list) and typing.get_origin(member) is list:
            return member
    return members[0] if len(members) == 1 else ann


def _describe(data: Any, path: Path) -> str:
    """``steps.2.args`` as a person reads it: ``step 'go' args``."""
    words: list[str] = []
    node = data
    for part in path:
        if isinstance(node, dict):
            node = node.get(part)
        elif isinstance(node, list) and isinstance(part, int) and part < len(node):
            node = node[part]
        else:
            node = None
        ident = node.get("id") if isinstance(part, int) and isinstance(node, dict) else None
        if isinstance(ident, str) and words and words[-1] in ("steps", "then", "else", "triggers"):
            words[-1] = f"{'trigger' if words[-1] == 'triggers' else 'step'} {ident!r}"
        elif isinstance(part, int) and words:
            words[-1] += f"[{part}]"
        else:
            words.append(str(part))
    return " ".join(words) or "the mission"


_KINDS = {
    "float": "a number",
    "int": "a whole number",
    "list": "a list",
    "dict": "a mapping",
    "model": "a mapping",
    "string": "text",
    "bool": "true or false",
}


def schema_problems(data: Any, smap: SourceMap, error: ValidationError) -> list[Problem]:
    """The problems of a document pydantic rejected, positioned through ``smap``."""
    problems: list[Problem] = []
    grouped: dict[Path, list[Any]] = {}
    errors = error.errors()
    for err in _of_the_meant_member(data, errors):
        grouped.setdefault(_data_path(data, tuple(err["loc"])), []).append(err)
    meant = _meant_fields(data, grouped)
    for path, group in grouped.items():
        if len(group) > 1 and {str(e["type"]) for e in group} <= _SHAPE_ERRORS | {"string_type"}:
            wanted = list(dict.fromkeys(_shape_wanted(e) for e in group))  # no member fits the value: say them all
            message = f"{_describe(data, path)}: expected {' or '.join(wanted)}, got {group[0]['input']!r}"
            problems.append(smap.problem(path, message))
            continue
        errs = _relevant(group)
        kinds = [str(e["type"]) for e in errs]
        where = _describe(data, path)
        keys = [e for e in errs if "[key]" in e["loc"]]
        if keys and keys[0]["type"] == "literal_error":
            allowed = re.findall(r"'([^']*)'", str(keys[0].get("ctx", {}).get("expected", "")))
            name = str(path[-1]) if path else "?"
            hint = f" (one of {', '.join(allowed)}{suggest(name, allowed).replace(' (', '; ').rstrip(')')})"
            problems.append(smap.problem(path, f"unknown key {name!r} in {_describe(data, path[:-1])}{hint}", key=True))
            continue
        if keys:
            problems.append(
                smap.problem(
                    path, f"{where}: a name must be letters, digits and _ (not starting with a digit)", key=True
                )
            )
            continue
        if "union_tag_invalid" in kinds:
            err = errs[kinds.index("union_tag_invalid")]
            given = err["input"].get("action") if isinstance(err["input"], dict) else None
            problems.append(smap.problem((*path, "action"), f"unknown action {given!r}{suggest(str(given), ACTIONS)}"))
            continue
        if "union_tag_not_found" in kinds:
            problems.append(smap.problem(path, f"{where}: a step needs an 'action' (one of {', '.join(ACTIONS)})"))
            continue
        template = [
            e
            for e in errs
            if (e["type"] == "string_pattern_mismatch" and "${" in str(e.get("ctx", {}).get("pattern", "")))
            or (e["type"] == "string_pattern_mismatch" and "\\$" in str(e.get("ctx", {}).get("pattern", "")))
        ]
        if template and len(errs) > len(template):
            wanted = sorted(
                {_KINDS.get(k.split("_")[0], k.split("_")[0]) for k in kinds if k != "string_pattern_mismatch"}
            )
            others = [e for e in errs if e not in template]
            detail = (
                others[0]["msg"]
                if len(others) == 1 and others[0]["type"] not in ("float_type", "float_parsing")
                else ""
            )
            given = errs[0]["input"]
            message = f"{where}: expected {' or '.join(wanted)} or a ${{...}} expression, got {given!r}"
            note = number_note(given) if {"float", "int"} & {k.split("_")[0] for k in kinds} else ""
            problems.append(smap.problem(path, message + (f" ({detail})" if detail else "") + note))
            continue
        if len(errs) > 1 and set(kinds) <= _SHAPE_ERRORS:  # a scalar where a list or a mapping goes
            wanted = sorted({_shape_wanted(e) for e in errs})
            problems.append(smap.problem(path, f"{where}: expected {' or '.join(wanted)}, got {errs[0]['input']!r}"))
            continue
        for err in errs:
            kind = err["type"]
            if kind in ("model_type", "model_attributes_type"):
                problems.append(smap.problem(path, f"{where}: expected {_shape_wanted(err)}, got {err['input']!r}"))
            elif kind == "extra_forbidden":
                field = str(path[-1]) if path else "?"
                model = _model_at(data, path[:-1])
                known = [f.alias or n for n, f in model.model_fields.items()] if model else []
                hint = suggest(field, known) or (f" (known: {', '.join(known)})" if known else "")
                problems.append(
                    smap.problem(path, f"unknown field {field!r} in {_describe(data, path[:-1])}{hint}", key=True)
                )
            elif kind == "missing":
                missing = str(err["loc"][-1]).rstrip("_")
                parent = path[:-1] if path and path[-1] == missing else path
                if (parent, missing) in meant:
                    continue  # an unknown field beside it is this one misspelt, and says so
                problems.append(smap.problem(parent, f"{_describe(data, parent)}: missing required field {missing!r}"))
            elif kind in ("too_short", "too_long") and "actual_length" in err.get("ctx", {}):
                ctx = err["ctx"]
                bound = f"at least {ctx['min_length']:,}" if kind == "too_short" else f"at most {ctx['max_length']:,}"
                count = ctx["min_length"] if kind == "too_short" else ctx["max_length"]
                items = "item" if count == 1 else "items"
                problems.append(smap.problem(path, f"{where}: {bound} {items}, not {ctx['actual_length']:,}"))
            else:
                message = str(err["msg"]).removeprefix("Value error, ")
                note = number_note(err["input"]) if kind in ("float_type", "int_type", "float_parsing") else ""
                problems.append(smap.problem(path, f"{where}: {message}{note}"))
    return problems


_SEXAGESIMAL = re.compile(r"[-+]?[0-9][0-9_]*(?::[0-5]?[0-9])+(?:\.[0-9_]*)?")
_OTHER_BASE = re.compile(r"[-+]?0(?:x[0-9a-fA-F_]+|o[0-7_]+|b[01_]+|[0-7_]+)")
_GROUPED = re.compile(r"[-+]?[0-9][0-9_]*(?:\.[0-9_]*)?")


def number_note(value: Any) -> str:
    """Why text written where a number goes is not one, for a message (``""`` when it is not text): a quoted
    number, or one of YAML 1.1's number forms, which missions read as text (:mod:`.source`).

    >>> number_note("1:30")
    ' (text, not a number: base-60 numbers are not read, YAML 1.1 would make it 90; write it in decimal)'
    >>> number_note("21.4134")
    ' (text, not a number: it is quoted; write it without quotes)'
    """
    if not isinstance(value, str):
        return ""
    text = value.strip()
    if _SEXAGESIMAL.fullmatch(text):
        sign = -1 if text.startswith("-") else 1
        total = 0.0
        for part in text.lstrip("+-").replace("_", "").split(":"):
            total = total * 60 + float(part)
        read = f"{sign * total:g}" if "." in text else str(sign * int(total))
        why = f"base-60 numbers are not read, YAML 1.1 would make it {read}; write it in decimal"
    elif _OTHER_BASE.fullmatch(text):
        why = "hexadecimal, octal, binary and leading-zero numbers are not read; write it in decimal, no leading 0"
    elif "_" in text and _GROUPED.fullmatch(text):
        why = "digits grouped with _ are not read; write it without the _"
    else:
        try:
            float(text)
        except ValueError:
            return ""
        why = "it is quoted; write it without quotes"
    return f" (text, not a number: {why})"


def _meant_fields(data: Any, grouped: dict[Path, list[Any]]) -> set[tuple[Path, str]]:
    """The missing fields an unknown field beside them is a misspelling of (``radius`` for ``radius_m``), by the
    mapping's path: the did-you-mean of the unknown field says it all."""
    missing: dict[Path, list[str]] = {}
    for path, group in grouped.items():
        for err in group:
            if err["type"] == "missing":
                name = str(err["loc"][-1]).rstrip("_")
                missing.setdefault(path[:-1] if path and path[-1] == name else path, []).append(name)
    meant: set[tuple[Path, str]] = set()
    for path, group in grouped.items():
        if path and any(e["type"] == "extra_forbidden" for e in group):
            match = difflib.get_close_matches(str(path[-1]), missing.get(path[:-1], []), n=1)
            meant.update((path[:-1], m) for m in match)
    return meant


_MODELS: dict[str, type[BaseModel]] = {
    name: model
    for module in (mission_values, mission_limits, action_args, mission_steps, policy_graph)
    for name, model in vars(module).items()
    if isinstance(model, type) and issubclass(model, BaseModel) and model is not BaseModel
}
_SHAPE_ERRORS = frozenset({"list_type", "dict_type", "model_type", "model_attributes_type"})


def _shape_wanted(err: Any) -> str:
    """What a list or mapping error wanted, as the author writes it: ``a mapping (lat, lon)``, ``a list``."""
    tag = next((str(p) for p in reversed(err["loc"]) if _union_tag(p)), "")
    if err["type"] == "string_type":
        return "a ${...} expression" if tag == "constrained-str" else "text"
    if err["type"] == "list_type":
        inner = _MODELS.get(tag.removeprefix("list[").removesuffix("]"))
        return (
            f"a list of mappings ({', '.join(f.alias or n for n, f in inner.model_fields.items())})"
            if inner
            else "a list"
        )
    model = _MODELS.get(str(err.get("ctx", {}).get("class_name", "")))
    fields = [f.alias or n for n, f in model.model_fields.items()] if model is not None else []
    return f"a mapping ({', '.join(fields)})" if fields else "a mapping"


_MAPPING_ERRORS = frozenset({"dict_type", "model_type", "model_attributes_type"})


def _relevant(errors: list[Any]) -> list[Any]:
    """Of the errors a union gives for one value, those of the member the value's shape chose (a list is not
    told it should have been a mapping)."""
    value = errors[0].get("input")
    if isinstance(value, int | float) and not isinstance(value, bool) and len(errors) > 1:
        return [e for e in errors if e["type"] != "string_type"]  # a number is not told it should be a ${...}
    if isinstance(value, list):
        kept = [e for e in errors if e["type"] not in _MAPPING_ERRORS]
    elif isinstance(value, dict):
        kept = [e for e in errors if e["type"] != "list_type"]
    else:
        kept = errors
    return kept or errors
