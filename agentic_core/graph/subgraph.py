"""Running a compiled graph as a node of another: namespaces, checkpoints, resumes and streamed events.

A subgraph compiled with ``checkpointer=None`` (the default) shares its parent's checkpointer under a namespace
of its own for each call (``node:task_id``), so an interrupt inside it pauses and resumes through the parent,
and a call that finished before a crash is not run again. ``checkpointer=True`` keeps one namespace per node,
so the subgraph remembers its state from one call to the next within a thread.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from .checkpoint.base import BaseCheckpointSaver
from .constants import STORE_KEY
from .context import _MISSING, TaskContext
from .errors import GraphError, GraphInterrupt
from .loop import Run, Sink
from .types import Command

if TYPE_CHECKING:
    from .compiled import CompiledStateGraph


@dataclass
class SubgraphCall:
    """Everything one call of a subgraph needs: where it checkpoints, what it gets, where its events go."""

    saver: BaseCheckpointSaver | None
    ns: str
    config: dict[str, Any]
    input: Any
    modes: frozenset[str]
    writer: Callable[[Any], None]
    sink: Sink | None


def prepare(graph: CompiledStateGraph, arg: Any, ctx: TaskContext) -> SubgraphCall:
    parent: Run = ctx.run
    inherit = graph.checkpointer is None or graph.checkpointer is True
    saver = parent.saver if inherit else graph._saver
    label = ctx.node if graph.checkpointer is True else f"{ctx.node}:{ctx.task_id}"
    ns = f"{parent.ns}|{label}" if parent.ns else label
    configurable = {**parent.configurable, "checkpoint_ns": ns, STORE_KEY: parent.store}
    configurable.pop("checkpoint_id", None)
    if hasattr(arg, "model_dump"):
        values = arg.model_dump()
    elif isinstance(arg, Mapping):
        values = dict(arg)
    else:
        raise GraphError(
            f"subgraph node {ctx.node!r} got {type(arg).__name__} {arg!r} as its input; a subgraph node takes a "
            "state: Send it a dict of the subgraph's keys"
        )
    sub_input: Any = {k: v for k, v in values.items() if k in graph.spec.schema.keys}
    existing = saver.get(parent.thread_id, ns) if saver is not None and parent.thread_id is not None else None
    if existing is not None:
        if existing.tasks:  # paused or cut short: continue it
            sub_input = Command(resume=ctx.fresh_resume) if ctx.fresh_resume is not _MISSING else None
        elif graph.checkpointer is not True:
            sub_input = None  # finished before the parent's step was saved: return its result, do not run again
    writer, sink, modes = ctx.writer, None, frozenset[str]()
    parent_sink = parent.sink
    if parent_sink is not None:
        name = ns.rsplit("|", 1)[-1]
        modes = parent.modes

        def sink(inner: tuple[str, ...], mode: str, chunk: Any) -> None:
            parent_sink((name, *inner), mode, chunk)

        def writer(chunk: Any) -> None:
            parent_sink((name,), "custom", chunk)

    return SubgraphCall(saver, ns, {**parent.config, "configurable": configurable}, sub_input, modes, writer, sink)


def finish(run: Run, ctx: TaskContext) -> dict[str, Any]:
    """The subgraph's result as the parent's update (its keys the parent knows), or its pause."""
    if run.interrupts:
        raise GraphInterrupt(tuple(run.interrupts))
    parent_keys = ctx.run.schema.keys
    return {k: v for k, v in run.output().items() if k in parent_keys}


def run_subgraph(graph: CompiledStateGraph, arg: Any, ctx: TaskContext) -> dict[str, Any]:
    call = prepare(graph, arg, ctx)
    gen = graph._drive(call.input, call.config, call.modes, call.saver, call.writer, ns=call.ns, sink=call.sink)
    while True:
        try:
            mode, chunk = next(gen)
        except StopIteration as stop:
            return finish(stop.value, ctx)
        if call.sink is not None:
            call.sink((), mode, chunk)


async def arun_subgraph(graph: CompiledStateGraph, arg: Any, ctx: TaskContext) -> dict[str, Any]:
    """The async twin: the subgraph's async nodes run on the caller's event loop."""
    call = prepare(graph, arg, ctx)
    run = Run(graph, call.config, saver=call.saver, modes=call.modes, ns=call.ns)
    run.sink = call.sink
    async for mode, chunk in graph._adrive(run, call.input, call.writer, None):
        if call.sink is not None:
            call.sink((), mode, chunk)
    return finish(run, ctx)
