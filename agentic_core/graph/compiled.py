"""``CompiledStateGraph``: invoke and stream a graph (sync and async), inspect and edit a thread's state."""

from __future__ import annotations

import queue
from collections.abc import AsyncIterator, Callable, Generator, Iterator, Mapping, Sequence
from functools import partial
from typing import TYPE_CHECKING, Any

from . import subgraph, thread_state
from .checkpoint.base import BaseCheckpointSaver, TaskOutcome, TaskSpec
from .errors import GraphError, reject_unsupported
from .execute import ParentCommand, run_task_async, run_task_sync
from .loop import Run, Sink
from .mermaid import DrawableGraph
from .types import STREAM_MODES, StateSnapshot

if TYPE_CHECKING:
    import asyncio
    from concurrent.futures import Future, ThreadPoolExecutor

    from .context import TaskContext
    from .graph import GraphSpec, StateGraph

StreamModeArg = str | Sequence[str] | None
SUBGRAPH_EVENT = "__subgraph__"
DONE_EVENT = "__done__"
MAX_WORKERS = 32  # threads for the sync nodes of one superstep; created only as tasks need them


def _noop(_: Any) -> None:
    return None


def _check_call(where: str, stream_mode: str, kwargs: dict[str, Any]) -> None:
    if stream_mode != "values":
        raise GraphError(f"{where} returns the final values; for stream_mode={stream_mode!r} use stream()")
    reject_unsupported(where, kwargs)


def _modes(stream_mode: StreamModeArg) -> tuple[list[str], bool]:
    """The requested stream modes, and whether chunks come as ``(mode, chunk)`` pairs."""
    modes = ["values"] if stream_mode is None else [stream_mode] if isinstance(stream_mode, str) else list(stream_mode)
    for mode in modes:
        if mode not in STREAM_MODES:
            raise GraphError(f"unknown stream_mode {mode!r}; choose from {', '.join(STREAM_MODES)}")
    return modes, not isinstance(stream_mode, str) and stream_mode is not None


def _shape(mode: str, chunk: Any, paired: bool, subgraphs: bool) -> Any:
    """A chunk as the caller asked for it: bare, ``(mode, chunk)``, or with the subgraph namespace first."""
    ns: tuple[str, ...] = ()
    if mode == SUBGRAPH_EVENT:
        ns, mode, chunk = chunk
    if subgraphs:
        return (ns, mode, chunk) if paired else (ns, chunk)
    return (mode, chunk) if paired else chunk


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
        store: Any = None,
    ) -> None:
        self.spec = spec
        self.store = store
        missing = [m for m in ("get", "put", "search") if store is not None and not callable(getattr(store, m, None))]
        if missing:
            raise GraphError(f"store must have the Store API (missing {', '.join(missing)}), got {store!r}")
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

    def _top_level_saver(self) -> BaseCheckpointSaver | None:
        if self.checkpointer is True:
            raise GraphError(
                "checkpointer=True means 'keep this subgraph's state in the parent's checkpointer'; a graph run "
                "on its own needs a real one: compile(checkpointer=InMemorySaver())"
            )
        return self._saver

    # --- running (sync) ---
    def invoke(
        self, input: Any, config: Mapping[str, Any] | None = None, *, stream_mode: str = "values", **kwargs: Any
    ) -> dict[str, Any]:
        """Run until END, an interrupt or a breakpoint; return the state (with ``__interrupt__`` if paused)."""
        _check_call("invoke()", stream_mode, kwargs)
        gen = self._drive(input, config, frozenset(), self._top_level_saver(), _noop)
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
        reject_unsupported("stream()", kwargs)
        modes, paired = _modes(stream_mode)
        events: queue.SimpleQueue[tuple[str, Any]] = queue.SimpleQueue()
        writer: Callable[[Any], None] = (lambda c: events.put(("custom", c))) if "custom" in modes else _noop
        sink: Sink | None = (lambda ns, m, c: events.put((SUBGRAPH_EVENT, (ns, m, c)))) if subgraphs else None
        live = events if "custom" in modes or subgraphs else None
        saver = self._top_level_saver()
        for mode, chunk in self._drive(input, config, frozenset(modes), saver, writer, live, sink=sink):
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
        """The sync driver: yields stream events, returns the finished (or paused) run."""
        run = Run(self, config, saver=saver, modes=modes, ns=ns)
        run.sink = sink
        run.start(input)
        yield from _drain(run)
        pool: ThreadPoolExecutor | None = None
        try:
            while (todo := run.begin_step()) is not None:
                yield from _drain(run)
                if len(todo) == 1 and events is None:
                    task = todo[0]
                    try:
                        run.record(task, run_task_sync(run, self.spec.nodes[task.node], task, writer))
                    except ParentCommand:
                        raise
                    except Exception as exc:
                        run.record_error(task, exc)
                        raise
                elif todo:
                    if pool is None:
                        from concurrent.futures import ThreadPoolExecutor

                        pool = ThreadPoolExecutor(max_workers=MAX_WORKERS)
                    yield from self._run_in_pool(run, todo, writer, pool, events)
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

    def _run_in_pool(
        self,
        run: Run,
        todo: list[TaskSpec],
        writer: Callable[[Any], None],
        pool: ThreadPoolExecutor,
        events: queue.SimpleQueue[tuple[str, Any]] | None,
    ) -> Iterator[tuple[str, Any]]:
        """Run a superstep's tasks in threads; pass on stream events while they run; save each as it ends."""
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
            if kind == DONE_EVENT:
                remaining -= 1
                _record_if_ok(run, by_id[item], futures[item])
            else:
                yield kind, item
        _settle(run, todo, futures)

    # --- running (async) ---
    async def ainvoke(
        self, input: Any, config: Mapping[str, Any] | None = None, *, stream_mode: str = "values", **kwargs: Any
    ) -> dict[str, Any]:
        """Async :meth:`invoke`: async nodes are awaited concurrently, sync nodes run in threads."""
        _check_call("ainvoke()", stream_mode, kwargs)
        run = Run(self, config, saver=self._top_level_saver(), modes=frozenset())
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

        reject_unsupported("astream()", kwargs)
        modes, paired = _modes(stream_mode)
        run = Run(self, config, saver=self._top_level_saver(), modes=frozenset(modes))
        loop = asyncio.get_running_loop()
        events: asyncio.Queue[tuple[str, Any]] = asyncio.Queue()

        def put(event: tuple[str, Any]) -> None:
            loop.call_soon_threadsafe(events.put_nowait, event)

        writer: Callable[[Any], None] = (lambda c: put(("custom", c))) if "custom" in modes else _noop
        if subgraphs:
            run.sink = lambda ns, m, c: put((SUBGRAPH_EVENT, (ns, m, c)))
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
        """The async driver. Cancelling it cancels the tasks of the running superstep."""
        import asyncio

        run.start(input)
        for item in _drain(run):
            yield item
        while (todo := run.begin_step()) is not None:
            for item in _drain(run):
                yield item
            tasks = {t.id: asyncio.ensure_future(run_task_async(run, self.spec.nodes[t.node], t, writer)) for t in todo}
            getter: asyncio.Future[Any] | None = None
            try:
                pending: set[asyncio.Future[Any]] = set(tasks.values())
                while pending:
                    if events is not None and getter is None:
                        getter = asyncio.ensure_future(events.get())
                    waiting = pending | ({getter} if getter is not None else set())
                    done, _ = await asyncio.wait(waiting, return_when=asyncio.FIRST_COMPLETED)
                    if getter is not None and getter in done:
                        event: tuple[str, Any] = getter.result()
                        getter = None
                        yield event
                    for task in todo:
                        if tasks[task.id] in done:
                            _record_if_ok(run, task, tasks[task.id])
                    pending -= done
                if events is not None:
                    await asyncio.sleep(0)  # let chunks sent just before the tasks ended arrive first
                    while not events.empty():
                        yield events.get_nowait()
            finally:
                for fut in [*tasks.values(), getter]:
                    if fut is not None and not fut.done():
                        fut.cancel()
            _settle(run, todo, tasks)
            run.end_step()
            for item in _drain(run):
                yield item
        for item in _drain(run):  # what the last begin_step said (a breakpoint)
            yield item
        if events is not None:
            while not events.empty():
                yield events.get_nowait()

    # --- as a node of another graph ---
    def _run_as_node(self, arg: Any, ctx: TaskContext) -> Any:
        return subgraph.run_subgraph(self, arg, ctx)

    async def _arun_as_node(self, arg: Any, ctx: TaskContext) -> Any:
        return await subgraph.arun_subgraph(self, arg, ctx)

    # --- state of a thread ---
    def get_state(self, config: Mapping[str, Any], *, subgraphs: bool = False) -> StateSnapshot:
        """The thread's newest checkpoint (or the one named by ``checkpoint_id``) as a :class:`StateSnapshot`."""
        reject_unsupported("get_state()", {"subgraphs": subgraphs})
        return thread_state.get_state(self, config)

    def get_state_history(
        self,
        config: Mapping[str, Any],
        *,
        filter: Mapping[str, Any] | None = None,
        before: Mapping[str, Any] | None = None,
        limit: int | None = None,
    ) -> Iterator[StateSnapshot]:
        """Every checkpoint of the thread, newest first; ``filter`` matches metadata, ``before`` a config."""
        return thread_state.get_state_history(self, config, filter, before, limit)

    def update_state(
        self, config: Mapping[str, Any], values: Mapping[str, Any] | Any | None, as_node: str | None = None
    ) -> dict[str, Any]:
        """Write ``values`` as if ``as_node`` had returned them, in a new checkpoint; returns its config.

        From an older ``checkpoint_id`` this forks the thread. With ``as_node`` (by default the node that ran
        last, when there was one) the next tasks are those that follow that node; ``as_node=END`` ends the run.
        At a pause in ``interrupt()`` the pause stays, so ``Command(resume=...)`` still continues it.
        """
        return thread_state.update_state(self, config, values, as_node)

    # --- seeing the graph ---
    def get_graph(self, config: Mapping[str, Any] | None = None, *, xray: bool | int = False) -> DrawableGraph:
        """The graph's structure, for ``draw_mermaid()``."""
        reject_unsupported("get_graph()", {"xray": xray})
        return DrawableGraph.from_builder(self.builder)


def _signal_done(q: queue.SimpleQueue[tuple[str, Any]], task_id: str, _: Future[TaskOutcome]) -> None:
    q.put((DONE_EVENT, task_id))


def _drain(run: Run) -> Iterator[tuple[str, Any]]:
    if run.events:
        items, run.events = run.events, []
        yield from items


def _record_if_ok(run: Run, task: TaskSpec, fut: Any) -> None:
    """Save a task's outcome the moment it finishes, so a crash later in the step does not re-run it."""
    if not fut.cancelled() and fut.exception() is None:
        run.record(task, fut.result())


def _settle(run: Run, todo: list[TaskSpec], futures: Mapping[str, Any]) -> None:
    """Once every task of the step is done: record the failures, then raise the first one (in task order)."""
    first: BaseException | None = None
    for task in todo:
        fut = futures[task.id]
        exc = fut.exception()
        if exc is None:
            if task.id not in run.outcomes and task.id not in run.open_interrupts:
                run.record(task, fut.result())
        elif isinstance(exc, ParentCommand):
            first = first or exc
        else:
            run.record_error(task, exc)
            first = first or exc
    if first is not None:
        raise first
