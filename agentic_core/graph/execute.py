"""Calling one node: its input, retries with backoff, timeout, and turning what it returned into an outcome.

Sync nodes run in the calling thread (or a worker thread when a superstep has several tasks); async nodes run on
an event loop. A sync node that times out cannot be killed: it is left to finish in its thread and its result
is discarded. Make a node async if it must be cancelled on timeout.
"""

from __future__ import annotations

import dataclasses
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from agentic_core.contracts.errors import AgenticUAVError

from .checkpoint.base import TaskOutcome, TaskSpec
from .context import _MISSING, TaskContext, _current
from .errors import GraphError, GraphInterrupt, NodeTimeoutError
from .graph import NodeSpec
from .types import Command, RetryPolicy, Send

if TYPE_CHECKING:
    from .loop import Run


class ParentCommand(AgenticUAVError):
    """A subgraph node returned ``Command(graph=Command.PARENT)``: the parent graph applies it."""

    def __init__(self, command: Command[Any]) -> None:
        super().__init__(command)
        self.command = command


def make_context(run: Run, task: TaskSpec, writer: Callable[[Any], None]) -> TaskContext:
    return TaskContext(
        node=task.node,
        task_id=task.id,
        ns=run.ns,
        config=run.config,
        has_checkpointer=run.saver is not None,
        writer=writer,
        resume=run.resume_lists.get(task.id, []),
        fresh_resume=run.fresh_resume.get(task.id, _MISSING),
        run=run,
        store=run.store,
    )


def _node_input(run: Run, task: TaskSpec) -> Any:
    return task.arg if task.push else run.schema.to_node_input(run.values)


def _kwargs(node: NodeSpec, ctx: TaskContext) -> dict[str, Any]:
    kwargs: dict[str, Any] = {}
    if node.takes_config:
        kwargs["config"] = ctx.config
    if node.takes_writer:
        kwargs["writer"] = ctx.writer
    if node.takes_store:
        kwargs["store"] = ctx.store
    return kwargs


def to_outcome(run: Run, node: str, returned: Any) -> TaskOutcome:
    """Validate what a node returned and split it into writes and routing."""
    goto: list[str | Send] = []
    update: Any = returned
    if isinstance(returned, Command):
        if returned.graph == Command.PARENT:
            raise ParentCommand(returned)
        goto = returned.goto_list()
        update = returned.update
    elif isinstance(returned, list | tuple) and returned and all(isinstance(c, Command) for c in returned):
        merged: dict[str, Any] = {}
        for cmd in returned:
            merged.update(cmd.update or {})
            goto.extend(cmd.goto_list())
        update = merged
    writes = run.checked_writes(node, update)
    return TaskOutcome(writes=writes, goto=goto)


def _delay_or_raise(run: Run, node: NodeSpec, task: TaskSpec, attempt: int, exc: Exception) -> float:
    """After a failed attempt: the seconds to wait before the next one, or re-raise (naming the node)."""
    policy: RetryPolicy | None = node.retry
    if isinstance(exc, ParentCommand):
        raise exc
    if policy is None or attempt >= policy.max_attempts or not policy.should_retry(exc):
        _annotate(exc, run, task, attempt)
        raise exc
    return policy.interval(attempt)


def _annotate(exc: BaseException, run: Run, task: TaskSpec, attempts: int) -> None:
    where = f"in node {task.node!r} (superstep {run.step + 1}"
    if run.thread_id is not None:
        where += f", thread {run.thread_id!r}"
    where += f", attempt {attempts})" if attempts > 1 else ")"
    exc.add_note(where)


def _timeout_error(node: NodeSpec) -> NodeTimeoutError:
    return NodeTimeoutError(
        f"node {node.name!r} did not finish within timeout_s={node.timeout_s}; raise timeout_s in add_node, "
        "or add a RetryPolicy that retries NodeTimeoutError"
    )


def _call_sync(node: NodeSpec, arg: Any, ctx: TaskContext) -> Any:
    """One attempt of a node from sync code, with its timeout."""
    if node.is_async:
        import asyncio  # imported on first use: it costs more at import than the rest of the runtime

    def target() -> Any:
        token = _current.set(ctx)
        try:
            if node.subgraph is not None:
                try:
                    return node.subgraph._run_as_node(arg, ctx)
                except ParentCommand as pc:  # a node of the subgraph routed in this (its parent) graph
                    return dataclasses.replace(pc.command, graph=None)
            if node.is_async:
                coro = node.fn(arg, **_kwargs(node, ctx))
                if node.timeout_s is not None:
                    coro = asyncio.wait_for(coro, node.timeout_s)
                return asyncio.run(coro)
            return node.fn(arg, **_kwargs(node, ctx))
        finally:
            _current.reset(token)

    needs_thread = node.timeout_s is not None and not node.is_async
    if node.is_async and _running_loop():
        needs_thread = True  # asyncio.run cannot nest in a thread that already runs a loop
    if not needs_thread:
        try:
            return target()
        except TimeoutError as exc:
            if node.is_async and node.timeout_s is not None and not isinstance(exc, GraphError):
                raise _timeout_error(node) from None
            raise
    box: dict[str, Any] = {}

    def runner() -> None:
        try:
            box["value"] = target()
        except BaseException as exc:
            box["error"] = exc

    thread = threading.Thread(target=runner, name=f"node-{node.name}", daemon=True)
    thread.start()
    thread.join(node.timeout_s)
    if thread.is_alive():
        raise _timeout_error(node)
    if "error" in box:
        raise box["error"]
    return box.get("value")


def _running_loop() -> bool:
    import asyncio

    try:
        asyncio.get_running_loop()
    except RuntimeError:
        return False
    return True


def run_task_sync(run: Run, node: NodeSpec, task: TaskSpec, writer: Callable[[Any], None]) -> TaskOutcome:
    """Run a task to an outcome: retried per its policy; an interrupt becomes an outcome, errors propagate."""
    attempt = 0
    while True:
        attempt += 1
        ctx = make_context(run, task, writer)
        try:
            returned = _call_sync(node, _node_input(run, task), ctx)
            return to_outcome(run, node.name, returned)
        except GraphInterrupt as gi:
            return TaskOutcome(interrupts=gi.interrupts, resume=list(ctx.resume))
        except Exception as exc:
            time.sleep(_delay_or_raise(run, node, task, attempt, exc))


async def run_task_async(run: Run, node: NodeSpec, task: TaskSpec, writer: Callable[[Any], None]) -> TaskOutcome:
    """The async twin of :func:`run_task_sync`: async nodes are awaited (and cancelled on timeout)."""
    import asyncio

    attempt = 0
    while True:
        attempt += 1
        ctx = make_context(run, task, writer)
        try:
            if node.subgraph is not None:
                token = _current.set(ctx)
                try:
                    returned = await node.subgraph._arun_as_node(_node_input(run, task), ctx)
                except ParentCommand as pc:
                    returned = dataclasses.replace(pc.command, graph=None)
                finally:
                    _current.reset(token)
            elif node.is_async:
                token = _current.set(ctx)
                try:
                    coro = node.fn(_node_input(run, task), **_kwargs(node, ctx))
                    if node.timeout_s is None:
                        returned = await coro
                    else:
                        try:
                            returned = await asyncio.wait_for(coro, node.timeout_s)
                        except TimeoutError:
                            raise _timeout_error(node) from None
                finally:
                    _current.reset(token)
            else:
                returned = await asyncio.to_thread(_call_sync, node, _node_input(run, task), ctx)
            return to_outcome(run, node.name, returned)
        except GraphInterrupt as gi:
            return TaskOutcome(interrupts=gi.interrupts, resume=list(ctx.resume))
        except Exception as exc:
            await asyncio.sleep(_delay_or_raise(run, node, task, attempt, exc))
