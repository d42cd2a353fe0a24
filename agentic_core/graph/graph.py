"""``StateGraph``: the builder. Nodes, edges, joins and routers are declared here and checked by ``compile()``."""

from __future__ import annotations

import inspect
import itertools
import typing
from collections.abc import Callable, Hashable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal, get_args, get_origin

from .constants import END, RESERVED_NAMES, START
from .errors import GraphCompileError, GraphError, InvalidRouteError, reject_unsupported
from .state import StateSchema
from .types import Command, RetryPolicy, Send

if TYPE_CHECKING:
    from .checkpoint import BaseCheckpointSaver
    from .compiled import CompiledStateGraph


def _closest(name: str, choices: Sequence[str]) -> str:
    import difflib

    match = difflib.get_close_matches(name, list(choices), n=1)
    return f" (did you mean {match[0]!r}?)" if match else ""


def _parameters(fn: Callable[..., Any]) -> frozenset[str]:
    """The parameter names of a node or router (read off the code object of a plain function: it is cheap)."""
    if inspect.isfunction(fn):
        code = fn.__code__
        return frozenset(code.co_varnames[: code.co_argcount + code.co_kwonlyargcount])
    try:
        return frozenset(inspect.signature(fn).parameters)
    except (TypeError, ValueError):
        return frozenset()


def _literal_values(annotation: Any) -> tuple[str, ...] | None:
    """The names in a ``Literal[...]`` (or ``Command[Literal[...]]``) return annotation, else None."""
    if get_origin(annotation) is Command or (isinstance(annotation, type) and annotation is Command):
        args = get_args(annotation)
        annotation = args[0] if args else None
    if get_origin(annotation) is Literal:
        return tuple(str(a) for a in get_args(annotation))
    return None


def _return_annotation(fn: Callable[..., Any]) -> Any:
    """The return annotation, resolved only when it can matter (it mentions Literal or Command); the raw text
    when it cannot be resolved (a forward reference to a class defined inside a function)."""
    target = fn if inspect.isfunction(fn) or inspect.ismethod(fn) else getattr(fn, "__call__", fn)  # noqa: B004
    raw = getattr(target, "__annotations__", {}).get("return")
    if raw is None or (isinstance(raw, str) and "Literal" not in raw and "Command" not in raw):
        return None
    try:
        return typing.get_type_hints(fn).get("return")
    except Exception:
        return raw if isinstance(raw, str) else None


def _literal_values_from_text(text: str) -> tuple[tuple[str, ...] | None, bool]:
    """Parse ``"Literal['a', 'b']"`` or ``"Command[Literal[...]]"`` without evaluating it.

    Returns the names (or None) and whether the annotation is a ``Command``."""
    import ast

    try:
        tree = ast.parse(text, mode="eval").body
    except SyntaxError:
        return None, False

    def name_of(node: ast.expr) -> str:
        if isinstance(node, ast.Attribute):
            return node.attr
        return node.id if isinstance(node, ast.Name) else ""

    is_command = name_of(tree.value if isinstance(tree, ast.Subscript) else tree) == "Command"
    if is_command and isinstance(tree, ast.Subscript):
        tree = tree.slice
    if isinstance(tree, ast.Subscript) and name_of(tree.value) == "Literal":
        items = tree.slice.elts if isinstance(tree.slice, ast.Tuple) else [tree.slice]
        if all(isinstance(i, ast.Constant) and isinstance(i.value, str) for i in items):
            return tuple(str(i.value) for i in items if isinstance(i, ast.Constant)), is_command
    return None, is_command


def _routes(annotation: Any) -> tuple[tuple[str, ...] | None, bool]:
    """The names a return annotation allows, and whether it is a ``Command`` (resolved or raw text)."""
    if annotation is None:  # most nodes and routers: nothing to resolve
        return None, False
    if isinstance(annotation, str):
        return _literal_values_from_text(annotation)
    is_command = annotation is Command or get_origin(annotation) is Command
    return _literal_values(annotation), is_command


@dataclass
class NodeSpec:
    """A node as registered: its callable (or subgraph), retry policy, timeout and known destinations."""

    name: str
    fn: Any  # a callable, or the CompiledStateGraph in ``subgraph``
    retry: RetryPolicy | None = None
    timeout_s: float | None = None
    destinations: tuple[str, ...] | None = None
    dynamic: bool = False
    takes_config: bool = False
    takes_writer: bool = False
    takes_store: bool = False
    is_async: bool = False
    subgraph: CompiledStateGraph | None = None
    metadata: dict[str, Any] = field(default_factory=dict)


@dataclass
class Branch:
    """A conditional edge: ``router(state)`` picks the next node(s), mapped through ``path_map``."""

    source: str
    router: Callable[..., Any]
    path_map: dict[Hashable, str] | None
    literal: tuple[str, ...] | None = None
    takes_config: bool = False
    is_async: bool = False

    @property
    def name(self) -> str:
        return getattr(self.router, "__name__", repr(self.router))

    def targets(self) -> set[str] | None:
        """The nodes this branch can route to, or None when it cannot be known before running."""
        if self.path_map is not None:
            return set(self.path_map.values())
        return None

    def resolve(self, result: Any) -> list[str | Send]:
        """Turn what the router returned into destinations, refusing names outside ``path_map``."""
        items = result if isinstance(result, list | tuple) else [result]
        out: list[str | Send] = []
        for item in items:
            if isinstance(item, Send):
                out.append(item)
            elif self.path_map is not None:
                try:
                    out.append(self.path_map[item])
                except (KeyError, TypeError):
                    allowed = ", ".join(repr(k) for k in self.path_map)
                    raise InvalidRouteError(
                        f"router {self.name!r} on edge from {self.source!r} returned {item!r}, which is not in its "
                        f"path_map (allowed: {allowed}); return one of those or add it to path_map"
                    ) from None
            elif isinstance(item, str):
                out.append(item)
            else:
                raise InvalidRouteError(
                    f"router {self.name!r} on edge from {self.source!r} returned {item!r}; without a path_map a "
                    "router must return node names, END or Send objects"
                )
        return out


@dataclass
class Join:
    """``add_edge([a, b], c)``: ``c`` runs once every source has finished since the last time it ran."""

    sources: tuple[str, ...]
    target: str

    @property
    def id(self) -> str:
        return "join:" + "+".join(self.sources) + ":" + self.target


@dataclass
class GraphSpec:
    """Everything ``compile()`` hands to the runtime, frozen at compile time."""

    schema: StateSchema
    nodes: dict[str, NodeSpec]
    edges: dict[str, list[str]] = field(default_factory=dict)
    joins: dict[str, list[Join]] = field(default_factory=dict)
    branches: dict[str, list[Branch]] = field(default_factory=dict)


class StateGraph:
    """A graph whose nodes read a shared, typed state and return updates to it (LangGraph's API).

    >>> from typing import TypedDict
    >>> from agentic_core.graph import StateGraph, START, END
    >>> class S(TypedDict):
    ...     count: int
    >>> g = StateGraph(S)
    >>> _ = g.add_node("inc", lambda s: {"count": s["count"] + 1})
    >>> _ = g.add_edge(START, "inc")
    >>> _ = g.add_edge("inc", END)
    >>> g.compile().invoke({"count": 41})
    {'count': 42}
    """

    def __init__(self, state_schema: Any, config_schema: Any = None, **kwargs: Any) -> None:
        reject_unsupported("StateGraph()", kwargs, harmless=("context_schema",))
        self.schema = StateSchema(state_schema)
        self.nodes: dict[str, NodeSpec] = {}
        self.edges: list[tuple[str, str]] = []
        self.joins: list[Join] = []
        self.branches: list[Branch] = []

    # --- building ---
    def add_node(
        self,
        node: str | Callable[..., Any] | CompiledStateGraph,
        action: Callable[..., Any] | CompiledStateGraph | None = None,
        *,
        retry: RetryPolicy | None = None,
        retry_policy: RetryPolicy | None = None,
        timeout_s: float | None = None,
        destinations: Sequence[str] | Mapping[str, str] | None = None,
        metadata: Mapping[str, Any] | None = None,
        **kwargs: Any,
    ) -> StateGraph:
        """Add a node: a function of the state returning an update dict, a ``Command`` or None; or a subgraph."""
        from .compiled import CompiledStateGraph

        if kwargs:
            reject_unsupported("add_node()", kwargs)
        if action is None:
            if isinstance(node, str):
                raise GraphError(f"add_node({node!r}) needs a function: add_node({node!r}, fn)")
            action, name = node, getattr(node, "__name__", None) or type(node).__name__
        else:
            if not isinstance(node, str):
                raise GraphError("add_node(name, fn): the name comes first and must be a string")
            name = node
        if name in RESERVED_NAMES:
            raise GraphError(f"{name!r} is reserved and cannot be a node name")
        if any(ch in name for ch in "|:"):
            raise GraphError(f"node name {name!r} may not contain '|' or ':'")
        if name in self.nodes:
            raise GraphError(f"node {name!r} is already in the graph; node names must be unique")
        if timeout_s is not None and timeout_s <= 0:
            raise GraphError(f"node {name!r}: timeout_s must be positive, got {timeout_s}")
        spec = NodeSpec(name=name, fn=action, retry=retry or retry_policy, timeout_s=timeout_s)
        spec.metadata = dict(metadata or {})
        if isinstance(action, CompiledStateGraph):
            spec.subgraph = action
        else:
            given: object = action  # users pass anything; the annotation is what we accept
            if not callable(given):
                raise GraphError(f"node {name!r}: {given!r} is not callable")
            params = _parameters(action)
            spec.takes_config = "config" in params
            spec.takes_writer = "writer" in params
            spec.takes_store = "store" in params
            spec.is_async = inspect.iscoroutinefunction(action) or (
                not inspect.isfunction(action)  # a plain function's __call__ is never a coroutine function
                and inspect.iscoroutinefunction(getattr(action, "__call__", None))  # noqa: B004 - async callables
            )
            literal, is_command = _routes(_return_annotation(action))
            if literal is not None:
                spec.destinations = literal
            elif is_command:
                spec.dynamic = True
        if destinations is not None:
            spec.destinations = tuple(destinations)
        self.nodes[name] = spec
        return self

    def add_edge(self, start_key: str | Sequence[str], end_key: str) -> StateGraph:
        """``add_edge(a, b)``: b runs after a. ``add_edge([a, b], c)``: c waits for both a and b."""
        if isinstance(start_key, str):
            if start_key == END:
                raise GraphError("END cannot be the start of an edge")
            if end_key == START:
                raise GraphError("START cannot be the end of an edge")
            self.edges.append((start_key, end_key))
        else:
            sources = tuple(start_key)
            if not sources:
                raise GraphError(f"add_edge([], {end_key!r}): a join needs at least one source")
            if START in sources or END in sources or end_key == START:
                raise GraphError(f"join into {end_key!r}: START/END cannot take part in a join")
            self.joins.append(Join(sources, end_key))
        return self

    def add_conditional_edges(
        self,
        source: str,
        path: Callable[..., Any],
        path_map: Mapping[Hashable, str] | Sequence[str] | None = None,
    ) -> StateGraph:
        """After ``source``, call ``path(state)`` and go where it says (a name, a list of names, or ``Send``s)."""
        if source == END:
            raise GraphError("END cannot have outgoing edges")
        literal, _ = _routes(_return_annotation(path))
        mapping: dict[Hashable, str] | None
        if path_map is None:
            mapping = {v: v for v in literal} if literal is not None else None
        elif isinstance(path_map, Mapping):
            mapping = dict(path_map)
        else:
            mapping = {v: v for v in path_map}
        self.branches.append(
            Branch(
                source=source,
                router=path,
                path_map=mapping,
                literal=literal,
                takes_config="config" in _parameters(path),
                is_async=inspect.iscoroutinefunction(path),
            )
        )
        return self

    def add_sequence(self, nodes: Sequence[Callable[..., Any] | tuple[str, Callable[..., Any]]]) -> StateGraph:
        """Add nodes and chain them with edges in the given order."""
        names: list[str] = []
        for item in nodes:
            if isinstance(item, tuple):
                self.add_node(item[0], item[1])
                names.append(item[0])
            else:
                self.add_node(item)
                names.append(list(self.nodes)[-1])
        for a, b in itertools.pairwise(names):
            self.add_edge(a, b)
        return self

    def set_entry_point(self, key: str) -> StateGraph:
        return self.add_edge(START, key)

    def set_finish_point(self, key: str) -> StateGraph:
        return self.add_edge(key, END)

    def set_conditional_entry_point(
        self, path: Callable[..., Any], path_map: Mapping[Hashable, str] | Sequence[str] | None = None
    ) -> StateGraph:
        return self.add_conditional_edges(START, path, path_map)

    # --- checking ---
    def _check_name(self, name: str, role: str, *, allow: tuple[str, ...] = ()) -> None:
        if name in self.nodes or name in allow:
            return
        raise GraphCompileError(
            f"{role} names unknown node {name!r}{_closest(name, list(self.nodes))}; "
            f"known nodes: {', '.join(self.nodes) or '(none)'}"
        )

    def validate(self, interrupt: Sequence[str] = ()) -> None:
        """Raise :class:`GraphCompileError` for unknown nodes, no entry point or nodes with no path to END.

        Each name is looked up first and the text naming where it was used is written only for an unknown one:
        a graph of a few thousand edges is checked without formatting a few thousand messages."""
        nodes = self.nodes
        for a, b in self.edges:
            if a not in nodes and a != START:
                self._check_name(a, f"edge {a!r} -> {b!r}", allow=(START,))
            if b not in nodes and b != END:
                self._check_name(b, f"edge {a!r} -> {b!r}", allow=(END,))
        for j in self.joins:
            for s in j.sources:
                if s not in nodes:
                    self._check_name(s, f"join edge {list(j.sources)!r} -> {j.target!r}")
            if j.target not in nodes and j.target != END:
                self._check_name(j.target, f"join edge {list(j.sources)!r} -> {j.target!r}", allow=(END,))
        for br in self.branches:
            if br.source not in nodes and br.source != START:
                self._check_name(br.source, f"conditional edge from {br.source!r}", allow=(START,))
            if br.path_map is not None:
                for key, tgt in br.path_map.items():
                    if tgt not in nodes and tgt != END:
                        self._check_name(tgt, f"path_map of router {br.name!r} (key {key!r})", allow=(END,))
                if br.literal is not None:
                    outside = [v for v in br.literal if v not in br.path_map]
                    if outside:
                        raise GraphCompileError(
                            f"router {br.name!r} on {br.source!r} is annotated to return {outside!r}, which "
                            f"path_map does not map; add them to path_map or fix the annotation"
                        )
        for spec in nodes.values():
            for d in spec.destinations or ():
                if d not in nodes and d != END:
                    self._check_name(d, f"destinations of node {spec.name!r}", allow=(END,))
        for name in interrupt:
            if name != "*":
                self._check_name(name, "interrupt_before/interrupt_after")
        if not any(a == START for a, _ in self.edges) and not any(b.source == START for b in self.branches):
            raise GraphCompileError("the graph has no entry point: add_edge(START, 'first_node')")
        self._check_paths_to_end()

    def successors(self) -> dict[str, set[str] | None]:
        """Each node's possible next nodes; None where they cannot be known before running."""
        succ: dict[str, set[str] | None] = {n: set() for n in [START, *self.nodes]}

        def add(src: str, targets: set[str] | None) -> None:
            cur = succ[src]
            if cur is None or targets is None:
                succ[src] = None
            else:
                cur |= targets

        for a, b in self.edges:
            add(a, {b})
        for j in self.joins:
            for s in j.sources:
                add(s, {j.target})
        for br in self.branches:
            add(br.source, br.targets())
        for spec in self.nodes.values():
            if spec.destinations is not None:
                add(spec.name, set(spec.destinations))
            elif spec.dynamic:
                add(spec.name, None)
        return succ

    def _check_paths_to_end(self) -> None:
        succ = self.successors()
        reaches: set[str] = {END}
        changed = True
        while changed:
            changed = False
            for node, targets in succ.items():
                if node in reaches:
                    continue
                if targets is None or targets & reaches:
                    reaches.add(node)
                    changed = True
        stuck = [n for n in self.nodes if n not in reaches]
        if stuck:
            hints = "; ".join(
                f"{n!r} has no outgoing edge" if not succ[n] else f"{n!r} only leads to {sorted(succ[n] or ())}"
                for n in stuck
            )
            raise GraphCompileError(
                f"node(s) {', '.join(map(repr, stuck))} have no path to END ({hints}). Add an edge to END, a "
                "conditional edge, or declare where a Command-returning node goes: "
                "add_node(name, fn, destinations=[...]) or annotate it '-> Command[Literal[...]]'"
            )

    def compile(
        self,
        checkpointer: BaseCheckpointSaver | bool | None = None,
        *,
        interrupt_before: Sequence[str] | str | None = None,
        interrupt_after: Sequence[str] | str | None = None,
        name: str | None = None,
        debug: bool = False,
        store: Any = None,
        **kwargs: Any,
    ) -> CompiledStateGraph:
        """Check the graph and return a runnable one. ``checkpointer=None`` in a subgraph inherits the parent's;
        ``store`` (any object with the Store API, e.g. ``agentic_core.memory.SqliteStore``) reaches nodes that take
        a ``store`` parameter, and ``get_store()``; a subgraph without one uses its parent's."""
        from .compiled import CompiledStateGraph

        reject_unsupported("compile()", {**kwargs, "debug": debug})
        before = [interrupt_before] if isinstance(interrupt_before, str) else list(interrupt_before or ())
        after = [interrupt_after] if isinstance(interrupt_after, str) else list(interrupt_after or ())
        self.validate([*before, *after])
        spec = GraphSpec(schema=self.schema, nodes=dict(self.nodes))
        for a, b in self.edges:
            spec.edges.setdefault(a, []).append(b)
        for j in self.joins:
            for s in j.sources:
                spec.joins.setdefault(s, []).append(j)
        for br in self.branches:
            spec.branches.setdefault(br.source, []).append(br)
        return CompiledStateGraph(
            spec,
            builder=self,
            checkpointer=checkpointer,
            interrupt_before=before,
            interrupt_after=after,
            name=name or "graph",
            store=store,
        )
