"""``CompiledStateGraph``: invoke, stream (sync and async), inspect and edit the state of a thread."""

from __future__ import annotations

import queue
from collections.abc import AsyncIterator, Callable, Generator, Iterator, Mapping, Sequence
from functools import partial
from typing import TYPE_CHECKING, Any

from .checkpoint.base import BaseCheckpointSaver, Checkpoint, TaskOutcome, TaskSpec, iso_time
from .constants import END, START
from .context import _MISSING, TaskContext
from .errors import CheckpointError, GraphError, GraphInterrupt, reject_unsupported
from .execute import ParentCommand, run_task_async, run_task_sync
from .loop import Run
from .mermaid import DrawableGraph
from .types import STREAM_MODES, Command, PregelTask, StateSnapshot

if TYPE_CHECKING:
    import asyncio
    from concurrent.futures import Future, ThreadPoolExecutor

    from .graph import GraphSpec, StateGraph

StreamModeArg = str | Sequence[str] | None


SUBGRAPH_EVENT = "__subgraph__"
Sink = Callable[[tuple[str, ...], str, Any], None]


def _noop(_: Any) -> None:
    return None


def _shape(mode: str, chunk: Any, paired: bool, subgraphs: bool) -> Any:
    """A chunk as the caller asked for it: bare, ``(mode, chunk)``, or with the subgraph namespace first."""
    ns: tuple[str, ...] = ()
    if mode == SUBGRAPH_EVENT:
        ns, mode, chunk = chunk
    if subgraphs:
        return (ns, mode, chunk) if paired else (ns, chunk)
    return (mode, chunk) if paired else chunk


def _check_call(where: str, stream_mode: str, kwargs: dict[str, Any]) -> None:
    if stream_mode != "values":
        raise GraphError(f"{where} returns the final values; for stream_mode={stream_mode!r} use stream()")
    reject_unsupported(where, kwargs, harmless=("debug",))


def _modes(stream_mode: StreamModeArg) -> tuple[list[str], bool]:
    """The requested stream modes, and whether chunks come as ``(mode, chunk)`` pairs."""
    modes = ["values"] if stream_mode is None else [stream_mode] if isinstance(stream_mode, str) else list(stream_mode)
    for mode in modes:
        if mode not in STREAM_MODES:
            raise GraphError(f"unknown stream_mode {mode!r}; choose from {', '.join(STREAM_MODES)}")
    return modes, not isinstance(stream_mode, str) and stream_mode is not None


class CompiledStateGraph:
    """A checked, runnable graph. Get one from ``StateGraph.compile()``."""

    def __init__(
        self,
        spec: GraphSpec,
        *,
        builder: StateGraph,
        checkpointer: BaseCheckpointSaver | bool | None,
        interrupt_before: list[str],
        interrupt_after: list[str],
        name: str,
    ) -> None:
        self.spec = spec
        self.builder = builder
        self.checkpointer = checkpointer
        self.interrupt_before = frozenset(interrupt_before)
        self.interrupt_after = frozenset(interrupt_after)
        self.name = name
        if checkpointer is not None and not isinstance(checkpointer, bool | BaseCheckpointSaver):
            raise GraphError(f"checkpointer must be InMemorySaver(), SqliteSaver(...) or None, got {checkpointer!r}")

    @property
    def _saver(self) -> BaseCheckpointSaver | None:
        return self.checkpointer if isinstance(self.checkpointer, BaseCheckpointSaver) else None

    # --- running (sync) ---
    def invoke(
        self, input: Any, config: Mapping[str, Any] | None = None, *, stream_mode: str = "values", **kwargs: Any
    ) -> dict[str, Any]:
        """Run until END, an interrupt or a breakpoint; return the state (with ``__interrupt__`` if paused)."""
        _check_call("invoke()", stream_mode, kwargs)
        gen = self._drive(input, config, frozenset(), self._saver, _noop)
        while True:
            try:
                next(gen)
            except StopIteration as stop:
                run: Run = stop.value
                return run.output()

    def stream(
        self,
        input: Any,
        config: Mapping[str, Any] | None = None,
        *,
        stream_mode: StreamModeArg = None,
        subgraphs: bool = False,
        **kwargs: Any,
    ) -> Iterator[Any]:
        """Yield as the run goes: ``values`` (state after each step), ``updates`` (each node's writes),
        ``debug`` (tasks and checkpoints) or ``custom`` (what nodes pass to ``get_stream_writer()``).

        With ``subgraphs=True`` every chunk comes with the namespace of the (sub)graph that produced it:
        ``(namespace, chunk)``, or ``(namespace, mode, chunk)`` when several modes are asked for."""
        reject_unsupported("stream()", kwargs, harmless=("debug",))
        modes, paired = _modes(stream_mode)
        events: queue.SimpleQueue[tuple[str, Any]] = queue.SimpleQueue()
        writer: Callable[[Any], None] = (lambda c: events.put(("custom", c))) if "custom" in modes else _noop
        sink = (lambda ns, m, c: events.put((SUBGRAPH_EVENT, (ns, m, c)))) if subgraphs else None
        live = events if "custom" in modes or subgraphs else None
        for mode, chunk in self._drive(input, config, frozenset(modes), self._saver, writer, live, sink=sink):
            yield _shape(mode, chunk, paired, subgraphs)

    def _drive(
        self,
        input: Any,
        config: Mapping[str, Any] | None,
        modes: frozenset[str],
        saver: BaseCheckpointSaver | None,
        writer: Callable[[Any], None],
        events: queue.SimpleQueue[tuple[str, Any]] | None = None,
        ns: str = "",
        sink: Sink | None = None,
    ) -> Generator[tuple[str, Any], None, Run]:
        run = Run(self, config, saver=saver, modes=modes, ns=ns)
        run.sink = sink
        run.start(input)
        yield from _drain(run)
        live = events is not None
        pool: ThreadPoolExecutor | None = None
        try:
            while (todo := run.begin_step()) is not None:
                yield from _drain(run)
                if not todo:
                    pass  # every task's outcome is already known (the input step, or a resumed step)
                elif len(todo) == 1 and not live:
                    task = todo[0]
                    try:
                        run.record(task, run_task_sync(run, self.spec.nodes[task.node], task, writer))
                    except Exception as exc:
                        run.record_error(task, exc)
                        raise
                else:
                    if pool is None:
                        from concurrent.futures import ThreadPoolExecutor

                        pool = ThreadPoolExecutor(max_workers=min(32, max(4, len(todo))))
                    done_q: queue.SimpleQueue[tuple[str, Any]] = events if events is not None else queue.SimpleQueue()
                    futures: dict[str, Future[TaskOutcome]] = {}
                    for task in todo:
                        fut = pool.submit(run_task_sync, run, self.spec.nodes[task.node], task, writer)
                        fut.add_done_callback(partial(_signal_done, done_q, task.id))
                        futures[task.id] = fut
                    by_id = {t.id: t for t in todo}
                    remaining = len(futures)
                    while remaining:
                        kind, item = done_q.get()
                        if kind == "__done__":
                            remaining -= 1
                            _record_if_ok(run, by_id[item], futures[item])
                        else:
                            yield kind, item
                    _settle(run, todo, futures)
                run.end_step()
                yield from _drain(run)
            yield from _drain(run)  # what the last begin_step said (a breakpoint)
            if events is not None:
                while not events.empty():
                    yield events.get()
        finally:
            if pool is not None:
                pool.shutdown(wait=False)
        return run

    # --- running (async) ---
    async def ainvoke(
        self, input: Any, config: Mapping[str, Any] | None = None, *, stream_mode: str = "values", **kwargs: Any
    ) -> dict[str, Any]:
        """Async :meth:`invoke`: async nodes are awaited concurrently, sync nodes run in threads."""
        _check_call("ainvoke()", stream_mode, kwargs)
        run = Run(self, config, saver=self._saver, modes=frozenset())
        async for _event in self._adrive(run, input, _noop, None):
            pass
        return run.output()

    async def astream(
        self,
        input: Any,
        config: Mapping[str, Any] | None = None,
        *,
        stream_mode: StreamModeArg = None,
        subgraphs: bool = False,
        **kwargs: Any,
    ) -> AsyncIterator[Any]:
        """Async :meth:`stream`."""
        import asyncio

        reject_unsupported("astream()", kwargs, harmless=("debug",))
        modes, paired = _modes(stream_mode)
        run = Run(self, config, saver=self._saver, modes=frozenset(modes))
        loop = asyncio.get_running_loop()
        events: asyncio.Queue[tuple[str, Any]] = asyncio.Queue()
        writer: Callable[[Any], None] = _noop
        if "custom" in modes:

            def writer(chunk: Any) -> None:
                loop.call_soon_threadsafe(events.put_nowait, ("custom", chunk))

        if subgraphs:
            run.sink = lambda ns, m, c: loop.call_soon_threadsafe(events.put_nowait, (SUBGRAPH_EVENT, (ns, m, c)))
        live = events if "custom" in modes or subgraphs else None
        async for mode, chunk in self._adrive(run, input, writer, live):
            yield _shape(mode, chunk, paired, subgraphs)

    async def _adrive(
        self,
        run: Run,
        input: Any,
        writer: Callable[[Any], None],
        events: asyncio.Queue[tuple[str, Any]] | None,
    ) -> AsyncIterator[tuple[str, Any]]:
        import asyncio

        run.start(input)
        for item in _drain(run):
            yield item
        while (todo := run.begin_step()) is not None:
            for item in _drain(run):
                yield item
            tasks = {t.id: asyncio.ensure_future(run_task_async(run, self.spec.nodes[t.node], t, writer)) for t in todo}
            pending: set[asyncio.Future[Any]] = set(tasks.values())
            getter: asyncio.Future[Any] | None = None
            while pending:
                waiting = pending | ({getter} if getter else set())
                if events is not None and getter is None:
                    getter = asyncio.ensure_future(events.get())
                    waiting.add(getter)
                done, _ = await asyncio.wait(waiting, return_when=asyncio.FIRST_COMPLETED)
                for task in todo:
                    if tasks[task.id] in done:
                        _record_if_ok(run, task, tasks[task.id])
                if getter is not None and getter in done:
                    event: tuple[str, Any] = getter.result()
                    yield event
                    getter = None
                pending -= done
            if getter is not None:
                getter.cancel()
            _settle(run, todo, tasks)
            run.end_step()
            for item in _drain(run):
                yield item
        for item in _drain(run):  # what the last begin_step said (a breakpoint)
            yield item
        if events is not None:
            while not events.empty():
                yield events.get_nowait()

    # --- subgraphs ---
    def _run_as_node(self, arg: Any, ctx: TaskContext) -> Any:
        """Run this graph as a node of a parent: shares the parent's checkpointer in a nested namespace."""
        parent: Run = ctx.run
        saver = parent.saver if self.checkpointer is None else self._saver
        ns = f"{parent.ns}|{ctx.node}:{ctx.task_id}" if parent.ns else f"{ctx.node}:{ctx.task_id}"
        configurable = {**parent.configurable, "checkpoint_ns": ns}
        configurable.pop("checkpoint_id", None)
        config = {**parent.config, "configurable": configurable}
        values = arg.model_dump() if hasattr(arg, "model_dump") else dict(arg)
        sub_input: Any = {k: v for k, v in values.items() if k in self.spec.schema.keys}
        if saver is not None and parent.thread_id is not None and saver.get(parent.thread_id, ns) is not None:
            sub_input = Command(resume=ctx.fresh_resume) if ctx.fresh_resume is not _MISSING else None
        parent_sink = parent.sink
        sink: Sink | None = None
        writer = ctx.writer
        modes: frozenset[str] = frozenset()
        if parent_sink is not None:
            label = ns.rsplit("|", 1)[-1]
            modes = parent.modes

            def sink(inner: tuple[str, ...], mode: str, chunk: Any) -> None:
                parent_sink((label, *inner), mode, chunk)

            def writer(chunk: Any) -> None:
                parent_sink((label,), "custom", chunk)

        gen = self._drive(sub_input, config, modes, saver, writer, ns=ns, sink=sink)
        while True:
            try:
                mode, chunk = next(gen)
            except StopIteration as stop:
                run: Run = stop.value
                break
            if sink is not None:
                sink((), mode, chunk)
        if run.interrupts:
            raise GraphInterrupt(tuple(run.interrupts))
        parent_keys = parent.schema.keys
        return {k: v for k, v in run.output().items() if k in parent_keys}

    # --- state of a thread ---
    def _require_saver(self, what: str, config: Mapping[str, Any] | None) -> tuple[BaseCheckpointSaver, str, str]:
        saver = self._saver
        if saver is None:
            raise CheckpointError(f"{what} needs a checkpointer: compile(checkpointer=InMemorySaver())")
        configurable = dict((config or {}).get("configurable") or {})
        if "thread_id" not in configurable:
            raise CheckpointError(f"{what} needs config={{'configurable': {{'thread_id': ...}}}}")
        return saver, str(configurable["thread_id"]), str(configurable.get("checkpoint_ns", ""))

    def _snapshot(self, thread_id: str, ns: str, ckpt: Checkpoint) -> StateSnapshot:
        def cfg(cid: str | None) -> dict[str, Any]:
            return {"configurable": {"thread_id": thread_id, "checkpoint_ns": ns, "checkpoint_id": cid}}

        values = {**self.spec.schema.defaults(), **ckpt.values} if self.spec.schema.is_model else dict(ckpt.values)
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
                    result=dict(out.writes) if out and not out.interrupted and out.error is None else None,
                )
            )
        return StateSnapshot(
            values=values,
            next=tuple(t.node for t in ckpt.tasks),
            config=cfg(ckpt.id),
            metadata=dict(ckpt.metadata),
            created_at=iso_time(ckpt.created_at),
            parent_config=cfg(ckpt.parent_id) if ckpt.parent_id else None,
            tasks=tuple(tasks),
        )

    def get_state(self, config: Mapping[str, Any], *, subgraphs: bool = False) -> StateSnapshot:
        """The thread's newest checkpoint (or the one named by ``checkpoint_id``) as a :class:`StateSnapshot`."""
        saver, thread_id, ns = self._require_saver("get_state", config)
        cid = (config.get("configurable") or {}).get("checkpoint_id")
        ckpt = saver.get(thread_id, ns, cid)
        if ckpt is None:
            return StateSnapshot(values={}, next=(), config=dict(config))
        return self._snapshot(thread_id, ns, ckpt)

    def get_state_history(
        self,
        config: Mapping[str, Any],
        *,
        filter: Mapping[str, Any] | None = None,
        before: Mapping[str, Any] | None = None,
        limit: int | None = None,
    ) -> Iterator[StateSnapshot]:
        """Every checkpoint of the thread, newest first; ``filter`` matches metadata, ``before`` a config."""
        saver, thread_id, ns = self._require_saver("get_state_history", config)
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
            yield self._snapshot(thread_id, ns, ckpt)

    def update_state(
        self, config: Mapping[str, Any], values: Mapping[str, Any] | Any | None, as_node: str | None = None
    ) -> dict[str, Any]:
        """Write ``values`` as if ``as_node`` had returned them, in a new checkpoint; returns its config.

        From an older ``checkpoint_id`` this forks the thread. With ``as_node`` the next tasks are those that
        follow that node; without it the pending tasks stay as they were. ``as_node=END`` ends the run.
        """
        saver, _, _ = self._require_saver("update_state", config)
        if as_node is not None and as_node not in self.spec.nodes and as_node not in (START, END):
            known = ", ".join(self.spec.nodes)
            raise GraphError(f"update_state(as_node={as_node!r}): no such node; known nodes: {known}")
        run = Run(self, config, saver=saver)
        ckpt = saver.get(run.thread_id or "", run.ns, run.configurable.get("checkpoint_id"))
        if ckpt is not None:
            run.load(ckpt)
        elif self.spec.schema.is_model:
            run.values = self.spec.schema.defaults()
        writer_name = as_node or "update_state"
        writes = run._checked_writes(writer_name, run.schema.update_to_dict(writer_name, values))
        changed = run.apply([(writer_name, writes)])
        if as_node == END:
            run.tasks = []
        elif as_node == START or (as_node is None and ckpt is None):
            run.tasks = run.plan([(TaskSpec("", START), TaskOutcome())])
        elif as_node is not None:
            run.tasks = run.plan([(TaskSpec("", as_node), TaskOutcome(writes=writes))])
        run.last_nodes = [writer_name]
        run.step += 1
        run.save("update", changed)
        return run.checkpoint_config()

    # --- seeing the graph ---
    def get_graph(self, config: Mapping[str, Any] | None = None, *, xray: bool | int = False) -> DrawableGraph:
        """The graph's structure, for ``draw_mermaid()``."""
        return DrawableGraph.from_builder(self.builder)


def _signal_done(q: queue.SimpleQueue[tuple[str, Any]], task_id: str, _: Future[TaskOutcome]) -> None:
    q.put(("__done__", task_id))


def _drain(run: Run) -> Iterator[tuple[str, Any]]:
    if run.events:
        items, run.events = run.events, []
        yield from items


def _record_if_ok(run: Run, task: TaskSpec, fut: Any) -> None:
    """Save a task's outcome the moment it finishes, so a crash later in the step does not re-run it."""
    if fut.exception() is None:
        run.record(task, fut.result())


def _settle(run: Run, todo: list[TaskSpec], futures: Mapping[str, Any]) -> None:
    """Once every task of the step is done: record the failures, then raise the first one (in task order)."""
    first: BaseException | None = None
    for task in todo:
        fut = futures[task.id]
        exc = fut.exception()
        if exc is None:
            if task.id not in run.outcomes:
                run.record(task, fut.result())
        elif isinstance(exc, ParentCommand):
            first = first or exc
        else:
            run.record_error(task, exc)
            first = first or exc
    if first is not None:
        raise first
