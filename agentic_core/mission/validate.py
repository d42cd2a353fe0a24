"""Validating missions: every problem of a file at once, each as ``file:line:col: message``.

Checks, in order: YAML syntax; the schema (mapped back to the line of the offending field); duplicate step
ids; ``depends_on`` naming steps that do not exist or that cannot be waited for; dependency cycles (printed as
the cycle); steps that can never run; expressions (syntax and unknown names); tools unknown to the registry;
and limits a step already breaks, through the flight envelope (:mod:`~agentic_core.mission.limits_check`).

>>> from agentic_core.mission.validate import load_mission
>>> load_mission("plan_id: P-1\\ngoal: hover\\nsteps:\\n  - {id: up, action: takeoff}\\n").plan_id
'P-1'
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path as FilePath
from typing import Any, NamedTuple

from pydantic import ValidationError

from agentic_core.contracts.input_files import InputFileError, check_input_file

from .expressions import Expression, ExpressionError
from .limits_check import LimitsCheck
from .model import ACTION_TOOLS, BranchStep, PolicyGraph, RepeatStep, Step, Trigger, WaitUntilStep, step_args
from .schema_errors import schema_problems, suggest
from .source import MissionError, Path, Problem, SourceMap, load_document
from .steps import SCOPE_ROOTS
from .templates import find_templates
from .tool_check import RUN_TOOLS, ToolCatalog, Validators, argument_problems, missing_scopes, unknown_tool_message


@dataclass(frozen=True)
class StepSite:
    """A step and where it sits: its path in the document, and the container it belongs to."""

    step: Step
    path: Path
    scope: str  # "plan", "nested:<parent id>" or "trigger:<trigger id>"


def walk_steps(steps: list[Step], base: Path = ("steps",), scope: str = "plan") -> Iterator[StepSite]:
    """``steps`` and every step nested in them (repeat bodies, branches), with their document paths."""
    for i, step in enumerate(steps):
        path = (*base, i)
        yield StepSite(step, path, scope)
        if isinstance(step, RepeatStep):
            yield from walk_steps(step.steps, (*path, "steps"), f"nested:{step.id}")
        elif isinstance(step, BranchStep):
            yield from walk_steps(step.then, (*path, "then"), f"nested:{step.id}")
            yield from walk_steps(step.else_, (*path, "else"), f"nested:{step.id}")


def iter_steps(plan: PolicyGraph) -> Iterator[StepSite]:
    """Every step of a mission, nested ones and trigger sub-plans included, with its document path."""
    yield from walk_steps(plan.steps)
    for t, trigger in enumerate(plan.triggers):
        yield from walk_steps(trigger.steps, ("triggers", t, "steps"), f"trigger:{trigger.id}")


def step_tool(step: Step) -> str | None:
    """The tool a step calls (``call_tool``'s own, an action's, none for the control steps)."""
    return getattr(step, "tool", None) if step.action == "call_tool" else ACTION_TOOLS.get(step.action)


def _template_path(where: str) -> Path:
    """``points[2].lat`` or ``['odd key']`` (as find_templates writes them) -> a document path."""
    parts: list[str | int] = []
    for name, index, quoted in re.findall(r"([A-Za-z_]\w*)|\[(\d+)\]|\['((?:[^'\\]|\\.)*)'\]", where):
        parts.append(name or (int(index) if index else quoted))
    return tuple(parts)


def _has_cycle(preds: Mapping[str, Iterable[str]]) -> bool:
    """Whether a dependency graph (each step -> the steps it waits for) has a cycle, in linear time: without one,
    the steps can all be taken away, one that waits for nothing left at a time (Kahn's algorithm)."""
    waiting: dict[str, int] = {}
    dependents: dict[str, list[str]] = {}
    for step_id, deps in preds.items():
        count = 0
        for dep in deps:
            dependents.setdefault(dep, []).append(step_id)
            count += 1
        waiting[step_id] = count
    ready = [step_id for step_id, count in waiting.items() if count == 0]
    removed = 0
    while ready:
        removed += 1
        for step_id in dependents.get(ready.pop(), ()):
            waiting[step_id] -= 1
            if waiting[step_id] == 0:
                ready.append(step_id)
    return removed < len(waiting)


class _Readable(NamedTuple):
    """The steps one step can count on having run: its ancestors as the bits of ``mask`` (a bit per step, see
    ``_Checker.ancestors``), and the steps in ``names``."""

    mask: int
    names: frozenset[str]


class _Checker:
    """The semantic checks, run on a mission that passed the schema."""

    def __init__(
        self,
        plan: PolicyGraph,
        smap: SourceMap,
        tools: ToolCatalog | None,
        outer_ids: tuple[str, ...] = (),
        home: tuple[float, float] | None = None,
    ) -> None:
        self.plan = plan
        self.home = home  # where north/east positions are measured from (None: they are checked in flight)
        self.smap = smap
        self.tools = tools
        self.outer_ids = outer_ids  # steps of the running mission a revision may read
        self.problems: list[Problem] = []
        self.sites = list(iter_steps(plan))
        self.by_id: dict[str, StepSite] = {}
        # the dependency graph, edges from a dependency to the step waiting for it; predecessors in the order
        # the edges were added (a dict: an edge given twice counts once)
        self.preds: dict[str, dict[str, None]] = {}
        self._bit: dict[str, int] = {}  # each step's bit in the ancestor masks
        self._ancestors: dict[str, int] = {}
        self._outer = frozenset(outer_ids)
        self._readable: dict[tuple[str, bool], _Readable] = {}
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
        self.check_scopes()
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
                        f"dependencies names unknown step {key!r}{suggest(key, self.by_id)}",
                        key=True,
                    )
                )
        preds = self.preds = {}
        for site in self.sites:
            step_id = site.step.id
            waits = preds.setdefault(step_id, {})
            extra = self.plan.dependencies.get(step_id)
            for dep in (*site.step.depends_on, *extra) if extra else site.step.depends_on:
                if self.waitable(site, dep):
                    waits[dep] = None  # the usual case: checked without building a path for a message
                    preds.setdefault(dep, {})
                else:
                    self.dependency_problems(site)
                    break
        self._bit = {step_id: 1 << i for i, step_id in enumerate(preds)}
        if _has_cycle(preds):
            self.report_cycles()

    def waitable(self, site: StepSite, dep: str) -> bool:
        """Whether ``site`` can wait for step ``dep``: it exists, is another step, and runs in the same list."""
        target = self.by_id.get(dep)
        return target is not None and dep != site.step.id and target.scope == site.scope

    def dependency_problems(self, site: StepSite) -> None:
        """The messages for a step that depends on something it cannot wait for (the edges it can are kept)."""
        for dep, path in self.deps_of(site):
            target = self.by_id.get(dep)
            if target is None:
                others = [i for i in self.by_id if i != site.step.id]
                self.add(path, f"step {site.step.id!r} depends on unknown step {dep!r}{suggest(dep, others)}")
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
                self.preds[site.step.id][dep] = None
                self.preds.setdefault(dep, {})

    def report_cycles(self) -> None:
        """One dependency cycle (printed as the cycle) per group of steps that wait for each other (a strongly
        connected component), and the steps that wait for one: linear time, however many cycles the steps make
        (12 mutually dependent steps make millions). Only a mission that has a cycle pays for networkx."""
        import networkx as nx

        graph = nx.DiGraph()
        for site in self.sites:
            graph.add_node(site.step.id)
            graph.add_edges_from((dep, site.step.id) for dep, _ in self.deps_of(site) if self.waitable(site, dep))

        def place(step_id: str) -> tuple[int, int]:
            return self.smap.at((*self.by_id[step_id].path, "id"))

        groups = sorted((sorted(c, key=place) for c in nx.strongly_connected_components(graph) if len(c) > 1),
                        key=lambda group: place(group[0]))  # fmt: skip
        in_cycle: set[str] = set()
        for group in groups:
            in_cycle |= set(group)
            cycle = [u for u, _ in nx.find_cycle(graph.subgraph(group), source=group[0])]
            first = min(cycle, key=place)
            i = cycle.index(first)
            ordered = [*cycle[i:], *cycle[:i]]
            text = " -> ".join([*ordered, ordered[0]])  # edges run from a dependency to the step that waits for it
            more = f"; {len(group)} steps wait for each other: {', '.join(group)}" if len(group) > len(cycle) else ""
            self.add(
                (*self.by_id[first].path, "depends_on"),
                f"dependency cycle: {text} (each must finish before the next, so none can start{more})",
            )
        blocked: set[str] = set()
        frontier = list(in_cycle)
        while frontier:
            for successor in graph.successors(frontier.pop()):
                if successor not in blocked:
                    blocked.add(successor)
                    frontier.append(successor)
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

    def readable(self, site: StepSite, *, own_body: bool = False) -> _Readable | None:
        """The steps whose outputs ``site`` can count on having (its dependencies, earlier steps of its body and
        what its parent can read); None where that cannot be known (a trigger's steps run at any time)."""
        if site.scope.startswith("trigger:"):
            return None
        key = (site.step.id, own_body)
        found = self._readable.get(key)
        if found is not None:
            return found
        if site.scope == "plan":
            found = _Readable(self.ancestors(site.step.id), self._outer)
        else:
            names = set(self.outer_ids)
            mask = 0
            parent = self.by_id.get(site.scope.split(":", 1)[1])
            if parent is not None:
                names.add(parent.step.id)
                above = self.readable(parent)
                if above is not None:
                    names |= above.names
                    mask = above.mask
            body, index = site.path[:-1], int(site.path[-1])
            names.update(self.bodies[body][:index])
            found = _Readable(mask, frozenset(names))
        if own_body:  # a repeat's until (and its body) may read the body's steps and the repeat itself
            found = _Readable(found.mask, found.names | {*self.bodies.get((*site.path, "steps"), []), site.step.id})
        self._readable[key] = found
        return found

    def ancestors(self, step_id: str) -> int:
        """Every step ``step_id`` waits for, directly or not, as the bits of those steps (memoised: shared across
        the plan's steps; an int OR merges hundreds of ancestors at once where sets would copy them)."""
        found = self._ancestors.get(step_id)
        if found is None:
            preds = self.preds.get(step_id)
            if preds is None:
                return 0
            self._ancestors[step_id] = 0  # a cycle ends here; cycles are reported on their own
            found = 0
            for dep in preds:
                found |= self.ancestors(dep) | self._bit[dep]
            self._ancestors[step_id] = found
        return found

    def check_expression(
        self,
        path: Path,
        text: str,
        known: tuple[str, ...],
        reader: StepSite | None = None,
        *,
        own_body: bool = False,
        known_set: frozenset[str] | None = None,
    ) -> None:
        """Check one expression: syntax, names (``known``; ``known_set`` is the same names as a set, when the
        caller has it), the steps it reads (``reader`` must wait for them) and the parameters it reads."""
        try:
            expr = Expression.parse(text)
            if known_set is None or not expr.root_names <= known_set:  # only an unknown name needs the message
                expr.check_names(known)
        except ExpressionError as exc:
            self.add(path, str(exc))
            return
        if reader is not None:
            refs = [ref for ref in (expr.root_names | expr.fields_of("steps")) if ref in self.by_id]
            allowed = self.readable(reader, own_body=own_body) if refs else None
            if allowed is not None:
                unsure = [ref for ref in refs if ref not in allowed.names and not allowed.mask & self._bit[ref]]
                for ref in sorted(unsure):
                    self.add(
                        path,
                        f"{text!r} reads step {ref!r}, which {reader.step.id!r} does not wait for: it may not have "
                        f"run yet; add {ref!r} to depends_on",
                    )
        for name in sorted(expr.fields_of("params")):
            if name not in self.plan.params:
                self.add(path, f"unknown parameter {name!r} in {text!r}{suggest(name, list(self.plan.params))}")

    def check_expressions(self) -> None:
        known = (*SCOPE_ROOTS, *self.by_id, *self.outer_ids)
        outside = tuple(n for n in known if n != "event")  # only a trigger's steps have an event
        known_set, outside_set = frozenset(known), frozenset(outside)
        for site in self.sites:
            in_trigger = site.scope.startswith("trigger:")
            names, name_set = (known, known_set) if in_trigger else (outside, outside_set)
            for path, text in self.expressions_of(site):
                own_body = path[-1] == "until"
                self.check_expression(path, text, names, site, own_body=own_body, known_set=name_set)
            try:
                templates = find_templates(step_args(site.step))
            except ExpressionError as exc:
                self.add((*site.path, "args"), str(exc))
                continue
            for where, expr in templates:
                path = (*site.path, "args", *_template_path(where))
                self.check_expression(path, expr.source, names, site, known_set=name_set)
        for t, trigger in enumerate(self.plan.triggers):
            self.check_expression(("triggers", t, "when"), trigger.when, known, known_set=known_set)

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
        validators: Validators = {}  # one per tool, for all its steps
        for site in self.sites:
            tool = getattr(site.step, "tool", None)
            if tool is None:
                continue
            if tool not in self.tools:
                self.add((*site.path, "tool"), unknown_tool_message(tool, self.tools))
                continue
            for where, message in argument_problems(tool, step_args(site.step), self.tools, validators):
                self.add((*site.path, "args", *where), message)

    def check_scopes(self) -> None:
        """A mission's ``scopes:`` must hold what the run itself calls and what every step's tool asks: an agent
        lacking one would fail in flight (or before take-off) on a file that could have been fixed."""
        if self.tools is None or self.plan.scopes is None or self.outer_ids:
            return  # no catalogue, no declared scopes, or a revision (its tools are reviewed against the agent)
        needs: dict[str, tuple[str, ...]] = {}
        where: dict[str, str] = {}
        for site in self.sites:
            tool = step_tool(site.step)
            if tool is not None and tool in self.tools and tool not in needs:
                needs[tool], where[tool] = tuple(self.tools.get(tool).scopes), f"step {site.step.id!r}"
        for tool in sorted(RUN_TOOLS):
            if tool in self.tools and tool not in needs:
                needs[tool], where[tool] = tuple(self.tools.get(tool).scopes), "the run itself"
        missing = missing_scopes(self.plan.scopes, needs)
        if missing:
            parts = [
                f"{scope} (for {', '.join(f'{t} in {where[t]}' for t in tools)})" for scope, tools in missing.items()
            ]
            self.add(
                ("scopes",),
                f"scopes leaves out {', '.join(missing)}, which this mission needs: {'; '.join(parts)}; add them, "
                "or leave scopes out to hold exactly what the tools ask",
            )

    def check_limits(self) -> None:
        check = LimitsCheck(self.plan, self.home)
        if not check.active:
            return
        for site in self.sites:
            for path, message in check.step(site.step, site.path):
                self.add(path, message)


def validate_document(
    data: Any, smap: SourceMap, tools: ToolCatalog | None = None, home: tuple[float, float] | None = None
) -> PolicyGraph:
    """Validate parsed mission data; raises :class:`MissionError` with every problem found. ``home`` (lat, lon)
    places north/east positions for the limits check."""
    if not isinstance(data, Mapping):
        kind = type(data).__name__
        raise MissionError(
            [*smap.problems, smap.problem((), f"a mission is a mapping with plan_id, goal and steps, not a {kind}")]
        )
    try:
        plan = PolicyGraph.model_validate(data)
    except ValidationError as exc:
        raise MissionError([*smap.problems, *schema_problems(data, smap, exc)]) from None
    problems = [*smap.problems, *_Checker(plan, smap, tools, home=home).run()]
    if problems:
        raise MissionError(problems)
    return plan


def check_revision(
    plan: PolicyGraph,
    steps: list[Step],
    mission_ids: Iterable[str],
    tools: ToolCatalog | None = None,
    *,
    event: bool = False,
) -> list[str]:
    """The problems of steps a reflector or planner proposes, checked like a mission's own (expressions, nesting,
    tools, limits) against the running mission's parameters and limits; ``event``: they answer a trigger, so they
    may read ``event``. Their ids must be new. Empty when they may be spliced in."""
    ids = tuple(mission_ids)
    if event:
        answer = Trigger.model_construct(id="__planned__", when="true", steps=steps, once=True, preempt=True)
        revision = plan.model_copy(update={"steps": [], "triggers": [answer], "dependencies": {}})
    else:
        revision = plan.model_copy(update={"steps": steps, "triggers": [], "dependencies": {}})
    taken = set(ids)
    reused = [f"step id {site.step.id!r} is already in the mission: use a new id" for site in iter_steps(revision)
              if site.step.id in taken]  # fmt: skip
    checker = _Checker(revision, SourceMap("<revision>"), tools, ids)
    return reused + [p.message for p in checker.run()]


def _line_col(raw: bytes, index: int) -> tuple[int, int]:
    before = raw[:index]
    return before.count(b"\n") + 1, index - (before.rfind(b"\n") + 1) + 1


def load_mission(
    source: str | FilePath,
    *,
    file: str | None = None,
    tools: ToolCatalog | None = None,
    home: tuple[float, float] | None = None,
) -> PolicyGraph:
    """Load and validate a mission from a path, or from YAML/JSON text (then ``file`` names it in messages).

    ``tools`` (a ``tools.ToolRegistry``) is what ``call_tool`` steps are checked against: the tool exists and the
    written arguments fit its schema; without it tools are not checked. ``home`` (lat, lon) is where north/east
    positions are measured from, so they are checked against the limits too; without it they are checked in flight.
    """
    if isinstance(source, FilePath) or (
        isinstance(source, str) and "\n" not in source and source.endswith((".yaml", ".yml", ".json"))
    ):
        path = FilePath(source)
        name = file or str(path)
        try:
            check_input_file(path, "mission")
            text = path.read_text(encoding="utf-8")
        except InputFileError as exc:
            raise MissionError([Problem(name, 1, 1, exc.reason)]) from None
        except OSError as exc:
            raise MissionError([Problem(name, 1, 1, f"cannot read the file: {exc.strerror or exc}")]) from None
        except UnicodeDecodeError as exc:
            line, col = _line_col(exc.object, exc.start)
            message = f"not UTF-8 text: byte 0x{exc.object[exc.start]:02x} cannot be read; save the file as UTF-8"
            raise MissionError([Problem(name, line, col, message)]) from None
    else:
        text, name = str(source), file or "<mission>"
    data, smap = load_document(text, name)
    return validate_document(data, smap, tools, home)
