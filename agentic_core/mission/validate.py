"""Validating missions: every problem of a file at once, each as ``file:line:col: message``.

Checks, in order: YAML syntax; the schema (mapped back to the line of the offending field); duplicate step
ids; ``depends_on`` naming steps that do not exist or that cannot be waited for; dependency cycles (printed as
the cycle); steps that can never run; expressions (syntax and unknown names); tools unknown to the registry;
and limits a step already breaks (a ``fly_to`` outside the geofence or above the maximum altitude).

>>> from agentic_core.mission.validate import load_mission
>>> load_mission("plan_id: P-1\\ngoal: hover\\nsteps:\\n  - {id: up, action: takeoff}\\n").plan_id
'P-1'
"""

from __future__ import annotations

import difflib
import re
import types
import typing
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path as FilePath
from typing import Any

import networkx as nx
from pydantic import BaseModel, ValidationError

from .expressions import Expression, ExpressionError, find_templates
from .geometry import Polygon, haversine_m
from .model import ACTIONS, STEP_MODELS, BranchStep, Circle, PolicyGraph, RepeatStep, Step, WaitUntilStep, step_args
from .source import MissionError, Path, Problem, SourceMap, load_document
from .steps import SCOPE_ROOTS
from .tool_check import ToolCatalog, argument_problems, unknown_tool_message


@dataclass(frozen=True)
class StepSite:
    """A step and where it sits: its path in the document, and the container it belongs to."""

    step: Step
    path: Path
    scope: str  # "plan", "nested:<parent id>" or "trigger:<trigger id>"


def iter_steps(plan: PolicyGraph) -> Iterator[StepSite]:
    """Every step of a mission, nested ones and trigger sub-plans included, with its document path."""

    def walk(steps: list[Step], base: Path, scope: str) -> Iterator[StepSite]:
        for i, step in enumerate(steps):
            path = (*base, i)
            yield StepSite(step, path, scope)
            if isinstance(step, RepeatStep):
                yield from walk(step.steps, (*path, "steps"), f"nested:{step.id}")
            elif isinstance(step, BranchStep):
                yield from walk(step.then, (*path, "then"), f"nested:{step.id}")
                yield from walk(step.else_, (*path, "else"), f"nested:{step.id}")

    yield from walk(plan.steps, ("steps",), "plan")
    for t, trigger in enumerate(plan.triggers):
        yield from walk(trigger.steps, ("triggers", t, "steps"), f"trigger:{trigger.id}")


def _suggest(word: str, choices: Iterable[str]) -> str:
    match = difflib.get_close_matches(word, list(choices), n=1)
    return f" (did you mean {match[0]!r}?)" if match else ""


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
        elif isinstance(part, str) and isinstance(node, dict) and part not in ACTIONS and part != "[key]":
            path.append(part)  # a missing field: its parent's position is used
            break
    return tuple(path)


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


def _schema_problems(data: Any, smap: SourceMap, error: ValidationError) -> list[Problem]:
    problems: list[Problem] = []
    grouped: dict[Path, list[Any]] = {}
    for err in error.errors():
        grouped.setdefault(_data_path(data, tuple(err["loc"])), []).append(err)
    for path, group in grouped.items():
        errs = _relevant(group)
        kinds = [str(e["type"]) for e in errs]
        where = _describe(data, path)
        if any("[key]" in e["loc"] for e in errs):
            problems.append(
                smap.problem(
                    path, f"{where}: a name must be letters, digits and _ (not starting with a digit)", key=True
                )
            )
            continue
        if "union_tag_invalid" in kinds:
            err = errs[kinds.index("union_tag_invalid")]
            given = err["input"].get("action") if isinstance(err["input"], dict) else None
            problems.append(smap.problem((*path, "action"), f"unknown action {given!r}{_suggest(str(given), ACTIONS)}"))
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
            message = f"{where}: expected {' or '.join(wanted)} or a ${{...}} expression, got {errs[0]['input']!r}"
            problems.append(smap.problem(path, message + (f" ({detail})" if detail else "")))
            continue
        for err in errs:
            kind = err["type"]
            if kind == "extra_forbidden":
                field = str(path[-1]) if path else "?"
                model = _model_at(data, path[:-1])
                known = [f.alias or n for n, f in model.model_fields.items()] if model else []
                hint = _suggest(field, known) or (f" (known: {', '.join(known)})" if known else "")
                problems.append(
                    smap.problem(path, f"unknown field {field!r} in {_describe(data, path[:-1])}{hint}", key=True)
                )
            elif kind == "missing":
                missing = str(err["loc"][-1]).rstrip("_")
                parent = path[:-1] if path and path[-1] == missing else path
                problems.append(smap.problem(parent, f"{_describe(data, parent)}: missing required field {missing!r}"))
            else:
                message = str(err["msg"]).removeprefix("Value error, ")
                problems.append(smap.problem(path, f"{where}: {message}"))
    return problems


def _fields(model: Any) -> dict[str, Any]:
    """A model's field values without pydantic's slow ``__getattr__`` for absent names (None gives {})."""
    return model.__dict__ if isinstance(model, BaseModel) else {}


def _template_path(where: str) -> Path:
    """``points[2].lat`` or ``['odd key']`` (as find_templates writes them) -> a document path."""
    parts: list[str | int] = []
    for name, index, quoted in re.findall(r"([A-Za-z_]\w*)|\[(\d+)\]|\['((?:[^'\\]|\\.)*)'\]", where):
        parts.append(name or (int(index) if index else quoted))
    return tuple(parts)


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


class _Checker:
    """The semantic checks, run on a mission that passed the schema."""

    def __init__(
        self, plan: PolicyGraph, smap: SourceMap, tools: ToolCatalog | None, outer_ids: tuple[str, ...] = ()
    ) -> None:
        self.plan = plan
        self.smap = smap
        self.tools = tools
        self.outer_ids = outer_ids  # steps of the running mission a revision may read
        self.problems: list[Problem] = []
        self.sites = list(iter_steps(plan))
        self.by_id: dict[str, StepSite] = {}
        self._fence: Polygon | None = None
        self.graph: nx.DiGraph = nx.DiGraph()
        self._readable: dict[tuple[str, bool], set[str]] = {}
        self._ancestors: dict[str, set[str]] = {}
        self.bodies: dict[Path, list[str]] = {}  # the step ids of each step list, in order, by its path
        for site in self.sites:
            self.bodies.setdefault(site.path[:-1], []).append(site.step.id)

    def add(self, path: Path, message: str) -> None:
        self.problems.append(self.smap.problem(path, message))

    def run(self) -> list[Problem]:
        self.check_ids()
        self.check_dependencies()
        self.check_expressions()
        self.check_nesting()
        self.check_tools()
        self.check_limits()
        return self.problems

    def check_ids(self) -> None:
        for site in self.sites:
            if site.step.id in SCOPE_ROOTS:
                self.add((*site.path, "id"), f"step id {site.step.id!r} would hide the expression name of that name")
            first = self.by_id.get(site.step.id)
            if first is not None:
                line = self.smap.at((*first.path, "id"))[0]
                self.add((*site.path, "id"), f"duplicate step id {site.step.id!r} (first at line {line})")
            else:
                self.by_id[site.step.id] = site
        trigger_ids = [t.id for t in self.plan.triggers]
        for t, trigger in enumerate(self.plan.triggers):
            if trigger.id in self.by_id or trigger_ids.index(trigger.id) != t:
                self.add(("triggers", t, "id"), f"trigger id {trigger.id!r} is already used")

    def deps_of(self, site: StepSite) -> list[tuple[str, Path]]:
        deps = [(d, (*site.path, "depends_on", j)) for j, d in enumerate(site.step.depends_on)]
        extra = self.plan.dependencies.get(site.step.id, [])
        deps += [(d, ("dependencies", site.step.id, j)) for j, d in enumerate(extra)]
        return deps

    def check_dependencies(self) -> None:
        for key in self.plan.dependencies:
            if key not in self.by_id:
                self.problems.append(
                    self.smap.problem(
                        ("dependencies", key),
                        f"dependencies names unknown step {key!r}{_suggest(key, self.by_id)}",
                        key=True,
                    )
                )
        graph = self.graph = nx.DiGraph()
        for site in self.sites:
            graph.add_node(site.step.id)
            for dep, path in self.deps_of(site):
                target = self.by_id.get(dep)
                if target is None:
                    others = [i for i in self.by_id if i != site.step.id]
                    self.add(path, f"step {site.step.id!r} depends on unknown step {dep!r}{_suggest(dep, others)}")
                elif dep == site.step.id:
                    self.add(path, f"step {site.step.id!r} depends on itself")
                elif target.scope != site.scope:
                    where = "inside " + target.scope.split(":", 1)[1] if target.scope != "plan" else "in the main plan"
                    self.add(
                        path,
                        f"step {site.step.id!r} depends on {dep!r}, which runs {where}: a step can only wait for "
                        "steps of the same list",
                    )
                else:
                    graph.add_edge(dep, site.step.id)
        in_cycle: set[str] = set()
        for cycle in nx.simple_cycles(graph):
            if len(cycle) < 2 or set(cycle) <= in_cycle:
                continue
            in_cycle |= set(cycle)
            first = min(cycle, key=lambda s: self.smap.at((*self.by_id[s].path, "id")))
            i = cycle.index(first)
            ordered = [*cycle[i:], *cycle[:i]]
            text = " -> ".join([*ordered, ordered[0]])  # edges run from a dependency to the step that waits for it
            self.add(
                (*self.by_id[first].path, "depends_on"),
                f"dependency cycle: {text} (each must finish before the next, so none can start)",
            )
        blocked = set().union(*(nx.descendants(graph, n) for n in in_cycle)) if in_cycle else set()
        for step_id in sorted(blocked):
            if step_id not in in_cycle:
                self.add(
                    (*self.by_id[step_id].path, "id"),
                    f"step {step_id!r} can never run: it waits (through depends_on) for a dependency cycle",
                )

    def expressions_of(self, site: StepSite) -> Iterator[tuple[Path, str]]:
        step = site.step
        for j, text in enumerate(step.preconditions):
            yield (*site.path, "preconditions", j), text
        if isinstance(step, WaitUntilStep):
            yield (*site.path, "condition"), step.condition
        if isinstance(step, RepeatStep):
            yield (*site.path, "until"), step.until
        if isinstance(step, BranchStep):
            yield (*site.path, "if"), step.if_

    def readable(self, site: StepSite, *, own_body: bool = False) -> set[str] | None:
        """The steps whose outputs ``site`` can count on having (its dependencies, earlier steps of its body and
        what its parent can read); None where that cannot be known (a trigger's steps run at any time)."""
        if site.scope.startswith("trigger:"):
            return None
        key = (site.step.id, own_body)
        if key in self._readable:
            return self._readable[key]
        found = set(self.outer_ids)
        if site.scope == "plan":
            found |= self.ancestors(site.step.id)
        else:
            parent = self.by_id.get(site.scope.split(":", 1)[1])
            if parent is not None:
                found |= {parent.step.id} | (self.readable(parent) or set())
            body, index = site.path[:-1], int(site.path[-1])
            found |= set(self.bodies[body][:index])
        if own_body:  # a repeat's until (and its body) may read the body's steps and the repeat itself
            found |= set(self.bodies.get((*site.path, "steps"), [])) | {site.step.id}
        self._readable[key] = found
        return found

    def ancestors(self, step_id: str) -> set[str]:
        """Every step ``step_id`` waits for, directly or not (memoised: shared across the plan's steps)."""
        found = self._ancestors.get(step_id)
        if found is None:
            if step_id not in self.graph:
                return set()
            self._ancestors[step_id] = set()  # a cycle ends here; cycles are reported on their own
            found = set()
            for dep in self.graph.predecessors(step_id):
                found |= self.ancestors(dep) | {dep}
            self._ancestors[step_id] = found
        return found

    def check_expression(
        self, path: Path, text: str, known: tuple[str, ...], reader: StepSite | None = None, *, own_body: bool = False
    ) -> None:
        try:
            expr = Expression.parse(text)
            expr.check_names(known)
        except ExpressionError as exc:
            self.add(path, str(exc))
            return
        refs = (expr.root_names | expr.fields_of("steps")) & self.by_id.keys() if reader is not None else set()
        allowed = self.readable(reader, own_body=own_body) if reader is not None and refs else None
        if reader is not None and allowed is not None:
            for ref in sorted(refs - allowed):
                self.add(
                    path,
                    f"{text!r} reads step {ref!r}, which {reader.step.id!r} does not wait for: it may not have "
                    f"run yet; add {ref!r} to depends_on",
                )
        for name in sorted(expr.fields_of("params")):
            if name not in self.plan.params:
                self.add(path, f"unknown parameter {name!r} in {text!r}{_suggest(name, list(self.plan.params))}")

    def check_expressions(self) -> None:
        known = (*SCOPE_ROOTS, *self.by_id, *self.outer_ids)
        outside = tuple(n for n in known if n != "event")  # only a trigger's steps have an event
        for site in self.sites:
            names = known if site.scope.startswith("trigger:") else outside
            for path, text in self.expressions_of(site):
                own_body = path[-1] == "until"
                self.check_expression(path, text, names, site, own_body=own_body)
            try:
                templates = find_templates(step_args(site.step))
            except ExpressionError as exc:
                self.add((*site.path, "args"), str(exc))
                continue
            for where, expr in templates:
                self.check_expression((*site.path, "args", *_template_path(where)), expr.source, names, site)
        for t, trigger in enumerate(self.plan.triggers):
            self.check_expression(("triggers", t, "when"), trigger.when, known)

    def check_nesting(self) -> None:
        for site in self.sites:
            if site.scope.startswith("nested:") and site.step.approval:
                parent = site.scope.split(":", 1)[1]
                self.add(
                    (*site.path, "approval"),
                    f"step {site.step.id!r} inside {parent!r} cannot ask for approval: the steps of a repeat or "
                    "branch run in one go, and a pause would run the earlier ones again; move it to the plan",
                )
            if not site.scope.startswith("nested:"):
                continue
            parent = site.scope.split(":", 1)[1]
            if site.step.action == "repeat":
                self.add((*site.path, "action"), f"a repeat inside {parent!r} is not supported")
            if site.step.depends_on:
                self.add(
                    (*site.path, "depends_on"),
                    f"steps inside {parent!r} run in the order they are listed; depends_on has no meaning there",
                )
            if site.step.on_fail not in ("skip", "retry", "abort"):
                self.add(
                    (*site.path, "on_fail"),
                    f"inside {parent!r} on_fail is skip, retry or abort: a failure fails {parent!r}, whose own "
                    "on_fail decides what happens next",
                )

    def check_tools(self) -> None:
        if self.tools is None:
            return
        for site in self.sites:
            tool = getattr(site.step, "tool", None)
            if tool is None:
                continue
            if tool not in self.tools:
                self.add((*site.path, "tool"), unknown_tool_message(tool, self.tools))
                continue
            for where, message in argument_problems(tool, step_args(site.step), self.tools):
                self.add((*site.path, "args", *where), message)

    def check_limits(self) -> None:
        limits = self.plan.limits
        for site in self.sites:
            args = _fields(site.step).get("args")
            for field in ("altitude_m", "alt_m"):
                value = _fields(args).get(field)
                if (
                    limits.max_altitude_m is not None
                    and isinstance(value, int | float)
                    and value > limits.max_altitude_m
                ):
                    self.add(
                        (*site.path, "args", field),
                        f"{site.step.action} to {value:g} m is above the mission's max_altitude_m "
                        f"({limits.max_altitude_m:g} m)",
                    )
            for label, point, path in self.points_of(site):
                if not self.inside_geofence(point):
                    self.add(
                        path, f"{site.step.action} {label} ({point[0]:.6f}, {point[1]:.6f}) is outside the geofence"
                    )

    def points_of(self, site: StepSite) -> Iterator[tuple[str, tuple[float, float], Path]]:
        args = _fields(_fields(site.step).get("args"))
        lat, lon = args.get("lat"), args.get("lon")
        if isinstance(lat, int | float) and isinstance(lon, int | float):
            yield "destination", (float(lat), float(lon)), (*site.path, "args", "lat")
        polygon = args.get("polygon")
        if isinstance(polygon, list):
            for j, p in enumerate(polygon):
                if isinstance(p.lat, int | float) and isinstance(p.lon, int | float):
                    yield f"polygon point {j}", (float(p.lat), float(p.lon)), (*site.path, "args", "polygon", j)
        center = args.get("center")
        if center is not None and isinstance(center.lat, int | float) and isinstance(center.lon, int | float):
            yield "center", (float(center.lat), float(center.lon)), (*site.path, "args", "center")

    def inside_geofence(self, point: tuple[float, float]) -> bool:
        fence = self.plan.limits.geofence
        if fence is None:
            return True
        if isinstance(fence, Circle):
            if not isinstance(fence.center.lat, int | float) or not isinstance(fence.center.lon, int | float):
                return True
            return haversine_m(point, (float(fence.center.lat), float(fence.center.lon))) <= fence.radius_m
        if self._fence is None:
            if not all(isinstance(p.lat, int | float) and isinstance(p.lon, int | float) for p in fence):
                return True  # a vertex given as ${...} is only known when the mission runs
            self._fence = Polygon([(float(p.lat), float(p.lon)) for p in fence])
        return self._fence.contains(point)


def validate_document(data: Any, smap: SourceMap, tools: ToolCatalog | None = None) -> PolicyGraph:
    """Validate parsed mission data; raises :class:`MissionError` with every problem found."""
    if not isinstance(data, Mapping):
        kind = type(data).__name__
        raise MissionError(
            [*smap.problems, smap.problem((), f"a mission is a mapping with plan_id, goal and steps, not a {kind}")]
        )
    try:
        plan = PolicyGraph.model_validate(data)
    except ValidationError as exc:
        raise MissionError([*smap.problems, *_schema_problems(data, smap, exc)]) from None
    problems = [*smap.problems, *_Checker(plan, smap, tools).run()]
    if problems:
        raise MissionError(problems)
    return plan


def check_revision(
    plan: PolicyGraph, steps: list[Step], mission_ids: Iterable[str], tools: ToolCatalog | None = None
) -> list[str]:
    """The problems of steps a reflector proposes, checked like a mission's own (expressions, nesting, tools,
    limits), against the running mission's parameters and limits. Empty when they may be spliced in."""
    revision = plan.model_copy(update={"steps": steps, "triggers": [], "dependencies": {}})
    checker = _Checker(revision, SourceMap("<revision>"), tools, tuple(mission_ids))
    return [p.message for p in checker.run()]


def _line_col(raw: bytes, index: int) -> tuple[int, int]:
    before = raw[:index]
    return before.count(b"\n") + 1, index - (before.rfind(b"\n") + 1) + 1


def load_mission(source: str | FilePath, *, file: str | None = None, tools: ToolCatalog | None = None) -> PolicyGraph:
    """Load and validate a mission from a path, or from YAML/JSON text (then ``file`` names it in messages).

    ``tools`` (a ``tools.ToolRegistry``) is what ``call_tool`` steps are checked against: the tool exists and the
    written arguments fit its schema; without it tools are not checked.
    """
    if isinstance(source, FilePath) or (
        isinstance(source, str) and "\n" not in source and source.endswith((".yaml", ".yml", ".json"))
    ):
        path = FilePath(source)
        name = file or str(path)
        try:
            text = path.read_text(encoding="utf-8")
        except OSError as exc:
            raise MissionError([Problem(name, 1, 1, f"cannot read the file: {exc.strerror or exc}")]) from None
        except UnicodeDecodeError as exc:
            line, col = _line_col(exc.object, exc.start)
            message = f"not UTF-8 text: byte 0x{exc.object[exc.start]:02x} cannot be read; save the file as UTF-8"
            raise MissionError([Problem(name, line, col, message)]) from None
    else:
        text, name = str(source), file or "<mission>"
    data, smap = load_document(text, name)
    return validate_document(data, smap, tools)
