"""Reading and editing a thread's state: ``get_state``, ``get_state_history`` and ``update_state``."""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import TYPE_CHECKING, Any

from .checkpoint.base import BaseCheckpointSaver, Checkpoint, TaskOutcome, TaskSpec, iso_time
from .constants import END, START
from .errors import CheckpointError, GraphError
from .loop import INPUT_NODE, Run, preview
from .types import PregelTask, StateSnapshot

if TYPE_CHECKING:
    from .compiled import CompiledStateGraph

UPDATE_NODE = "update_state"


def require_saver(
    graph: CompiledStateGraph, what: str, config: Mapping[str, Any] | None
) -> tuple[BaseCheckpointSaver, str, str]:
    saver = graph._saver
    if saver is None:
        raise CheckpointError(f"{what} needs a checkpointer: compile(checkpointer=InMemorySaver())")
    configurable = dict((config or {}).get("configurable") or {})
    if configurable.get("thread_id") is None:
        raise CheckpointError(f"{what} needs config={{'configurable': {{'thread_id': ...}}}}")
    return saver, str(configurable["thread_id"]), str(configurable.get("checkpoint_ns", ""))


def snapshot(graph: CompiledStateGraph, thread_id: str, ns: str, ckpt: Checkpoint) -> StateSnapshot:
    """A checkpoint as users see it: finished tasks of a paused step are applied and no longer ``next``."""

    def cfg(cid: str | None) -> dict[str, Any]:
        return {"configurable": {"thread_id": thread_id, "checkpoint_ns": ns, "checkpoint_id": cid}}

    starts = {t.id for t in ckpt.tasks if t.node == START}
    finished = {
        tid: o for tid, o in ckpt.outcomes.items() if not o.interrupted and o.error is None and tid not in starts
    }
    tasks = []
    for t in ckpt.tasks:
        out = ckpt.outcomes.get(t.id)
        tasks.append(
            PregelTask(
                id=t.id,
                name=t.node,
                path=("push" if t.push else "pull", t.node),
                error=out.error if out else None,
                interrupts=out.interrupts if out else (),
                result=dict(out.writes) if t.id in finished and out else None,
            )
        )
    return StateSnapshot(
        values=preview(graph.spec.schema, ckpt.values, ckpt.tasks, finished),
        next=tuple(t.node for t in ckpt.tasks if t.id not in finished),
        config=cfg(ckpt.id),
        metadata=dict(ckpt.metadata),
        created_at=iso_time(ckpt.created_at),
        parent_config=cfg(ckpt.parent_id) if ckpt.parent_id else None,
        tasks=tuple(tasks),
    )


def get_state(graph: CompiledStateGraph, config: Mapping[str, Any]) -> StateSnapshot:
    saver, thread_id, ns = require_saver(graph, "get_state", config)
    ckpt = saver.get(thread_id, ns, (config.get("configurable") or {}).get("checkpoint_id"))
    if ckpt is None:
        return StateSnapshot(values={}, next=(), config=dict(config))
    return snapshot(graph, thread_id, ns, ckpt)


def get_state_history(
    graph: CompiledStateGraph,
    config: Mapping[str, Any],
    filter: Mapping[str, Any] | None,
    before: Mapping[str, Any] | None,
    limit: int | None,
) -> Iterator[StateSnapshot]:
    saver, thread_id, ns = require_saver(graph, "get_state_history", config)
    before_id = ((before or {}).get("configurable") or {}).get("checkpoint_id")
    seen_before = before_id is None
    count = 0
    for ckpt in saver.list(thread_id, ns):
        if not seen_before:
            seen_before = ckpt.id == before_id
            continue
        if filter and any(ckpt.metadata.get(k) != v for k, v in filter.items()):
            continue
        if limit is not None and count >= limit:
            return
        count += 1
        yield snapshot(graph, thread_id, ns, ckpt)


def update_state(
    graph: CompiledStateGraph, config: Mapping[str, Any], values: Any, as_node: str | None
) -> dict[str, Any]:
    """See :meth:`CompiledStateGraph.update_state`."""
    saver, _, _ = require_saver(graph, "update_state", config)
    if as_node is not None and as_node not in graph.spec.nodes and as_node not in (START, END):
        known = ", ".join(graph.spec.nodes)
        raise GraphError(f"update_state(as_node={as_node!r}): no such node; known nodes: {known}")
    run = Run(graph, config, saver=saver)
    assert run.thread_id is not None
    ckpt = saver.get(run.thread_id, run.ns, run.configurable.get("checkpoint_id"))
    if ckpt is not None:
        run.load(ckpt)
    else:
        run.values = graph.spec.schema.initial_values()
    paused = bool(run.open_interrupts)
    if as_node is None and ckpt is not None and not paused:
        ran = {n for n in ckpt.metadata.get("ran", []) if n not in (START, INPUT_NODE, UPDATE_NODE)}
        if len(ran) == 1:
            as_node = ran.pop()  # as LangGraph: the update is taken as the last node's, and its edges re-run
    writer_name = as_node or UPDATE_NODE
    writes = run.checked_writes(writer_name, values)
    changed = run.apply([(writer_name, writes)])
    if as_node == END:
        run.tasks = []
    elif as_node == START or (as_node is None and ckpt is None):
        run.tasks = run.plan([(TaskSpec("", START), TaskOutcome())])
    elif as_node is not None:
        run.tasks = run.plan([(TaskSpec("", as_node), TaskOutcome(writes=writes))])
    elif not paused:
        # the pending tasks run again on the new values: new ids, so a subgraph among them starts afresh
        run.tasks = [run.new_task(t.node, push=t.push, arg=t.arg) for t in run.tasks]
    if as_node is not None or not paused:
        run.outcomes, run.open_interrupts, run.resume_lists = {}, {}, {}
    run.last_nodes = [writer_name]
    run.step += 1
    run.save("update", changed)
    run.carry_outcomes()  # paused at interrupt(): the pause and the finished siblings stay
    return run.checkpoint_config()
