"""One run of a compiled graph as a state machine: load, take input, plan supersteps, apply the barrier, save.

The drivers in ``compiled.py`` (sync and async) only execute the tasks this class hands them; every rule about
what runs next, how writes merge and what gets checkpointed lives here, once.
"""

from __future__ import annotations

import copy
import os
import time
from collections.abc import Callable, Iterable, Mapping
from typing import TYPE_CHECKING, Any

from .checkpoint.base import Checkpoint, TaskOutcome, TaskSpec, diff_values, iso_time
from .constants import END, INTERRUPT_KEY, START, STORE_KEY
from .errors import (
    CheckpointError,
    EmptyInputError,
    GraphError,
    GraphRecursionError,
    InvalidRouteError,
    InvalidUpdateError,
)
from .state import MISSING, StateSchema
from .types import Command, Interrupt, Send

if TYPE_CHECKING:
    from .checkpoint import BaseCheckpointSaver
    from .compiled import CompiledStateGraph

DEFAULT_RECURSION_LIMIT = 10_000
INPUT_NODE = "__input__"
Sink = Callable[[tuple[str, ...], str, Any], None]


def merge_writes(
    schema: StateSchema, values: dict[str, Any], writes: Iterable[tuple[str, list[tuple[str, Any]]]]
) -> set[str]:
    """Merge writes into ``values`` in the given order: reducers fold, last-value keys take one writer a step."""
    written_by: dict[str, str] = {}
    changed: set[str] = set()
    keys = schema.keys
    for node, items in writes:
        for key, value in items:
            spec = keys[key]
            if spec.reducer is None:
                if key in written_by:
                    raise InvalidUpdateError(
                        f"nodes {written_by[key]!r} and {node!r} both wrote last-value key {key!r} in the same "
                        f"superstep; give {key!r} a reducer (Annotated[T, reducer]) or let one node write it"
                    )
                written_by[key] = node
                values[key] = value
            else:
                base = values[key] if key in values else spec.initial()
                try:
                    values[key] = value if base is MISSING else spec.reducer(base, value)
                except (ValueError, TypeError) as exc:  # the reducer refused the value: say whose write it was
                    name = getattr(spec.reducer, "__name__", "reducer")
                    raise InvalidUpdateError(f"node {node!r} wrote key {key!r}, which {name} refused: {exc}") from exc
            changed.add(key)
    return changed


def run_sync(awaitable: Any) -> Any:
    """Run a coroutine to its result from sync code, also when this thread already runs an event loop."""
    import asyncio

    try:
        asyncio.get_running_loop()
    except RuntimeError:
        return asyncio.run(awaitable)
    box: dict[str, Any] = {}

    def target() -> None:
        try:
            box["value"] = asyncio.run(awaitable)
        except BaseException as exc:
            box["error"] = exc

    import threading

    thread = threading.Thread(target=target, daemon=True)
    thread.start()
    thread.join()
    if "error" in box:
        raise box["error"]
    return box["value"]


class Run:
    """The state of one invocation: values, the next tasks, join barriers, and the outcomes of this step."""

    def __init__(
        self,
        graph: CompiledStateGraph,
        config: Mapping[str, Any] | None,
        *,
        saver: BaseCheckpointSaver | None,
        modes: frozenset[str] = frozenset(),
        ns: str = "",
    ) -> None:
        self.graph = graph
        self.spec = graph.spec
        self.schema = graph.spec.schema
        self.config: dict[str, Any] = dict(config or {})
        self.configurable: dict[str, Any] = dict(self.config.get("configurable") or {})
        self.saver = saver
        self.store: Any = graph.store if graph.store is not None else self.configurable.get(STORE_KEY)
        tid = self.configurable.get("thread_id")
        self.thread_id: str | None = None if tid is None else str(tid)
        if saver is not None and self.thread_id is None:
            raise CheckpointError(
                "this graph has a checkpointer, so every call needs a thread id: "
                "pass config={'configurable': {'thread_id': 'some-id'}}"
            )
        self.ns = ns or str(self.configurable.get("checkpoint_ns", ""))
        limit = self.config.get("recursion_limit", DEFAULT_RECURSION_LIMIT)
        if not isinstance(limit, int) or limit < 1:
            raise GraphError(f"recursion_limit must be a positive integer, got {limit!r}")
        self.limit = limit
        self.modes = modes
        self.events: list[tuple[str, Any]] = []
        self.sink: Sink | None = None  # where a subgraph's events go when the caller streams with subgraphs=True
        self.values: dict[str, Any] = {}
        self.tasks: list[TaskSpec] = []
        self.joins: dict[str, list[str]] = {}
        self.step = -1
        self.checkpoint_id: str | None = None
        self.outcomes: dict[str, TaskOutcome] = {}  # finished tasks of the current step
        self.open_interrupts: dict[str, TaskOutcome] = {}  # tasks of the current step paused in interrupt()
        self.resume_lists: dict[str, list[Any]] = {}
        self.fresh_resume: dict[str, Any] = {}
        self.at_breakpoint = False
        self.skip_breakpoint = False
        self.steps_run = 0
        self.interrupts: list[Interrupt] = []
        self.stopped = False
        self.last_nodes: list[str] = []
        self._saved_lists: dict[str, list[Any]] = {}
        self._token = os.urandom(8).hex()
        self._seq = 0

    # --- events and what callers see ---
    def emit(self, mode: str, chunk: Any) -> None:
        if mode in self.modes:
            self.events.append((mode, chunk))

    def visible_values(self) -> dict[str, Any]:
        """The values, with the writes of tasks that finished in a paused superstep applied (as LangGraph shows)."""
        if not self.outcomes:
            return dict(self.values)
        return preview(self.schema, self.values, self.tasks, self.outcomes)

    def output(self) -> dict[str, Any]:
        out = self.visible_values()
        if self.interrupts:
            out[INTERRUPT_KEY] = list(self.interrupts)
        return out

    # --- loading and input ---
    def load(self, ckpt: Checkpoint) -> None:
        self.values = dict(ckpt.values)
        self.tasks = list(ckpt.tasks)
        self.joins = {k: list(v) for k, v in ckpt.joins.items()}
        self.step = ckpt.step
        self.checkpoint_id = ckpt.id
        self.at_breakpoint = ckpt.at_breakpoint
        self.last_nodes = list(ckpt.metadata.get("ran", []))
        for tid, out in ckpt.outcomes.items():
            if out.interrupted:
                self.open_interrupts[tid] = out
            elif out.error is None:
                self.outcomes[tid] = out
            if (out.resume and out.error is not None) or out.interrupted:
                self.resume_lists[tid] = list(out.resume)  # answers given before an error or crash are kept
        self._saved_lists = {k: list(v) for k, v in self.values.items() if type(v) is list}

    def start(self, input: Any) -> None:
        """Load the thread's checkpoint (if any) and take ``input``: new values, ``None`` or a ``Command``.

        New values become the outcome of a ``__start__`` task, run as a superstep like any other (as in
        LangGraph): a checkpoint before the input is applied, one after, and the step counts towards the limit.
        """
        ckpt = None
        if self.saver is not None:
            assert self.thread_id is not None
            ckpt = self.saver.get(self.thread_id, self.ns, self.configurable.get("checkpoint_id"))
        if ckpt is not None:
            self.load(ckpt)
        else:
            self.values = self.schema.initial_values()
        if input is None:
            if ckpt is None:
                where = f"thread {self.thread_id!r}" if self.saver else "a graph without a checkpointer"
                raise EmptyInputError(f"invoke(None) resumes a paused run, but {where} has nothing to resume")
            self.skip_breakpoint = self.at_breakpoint
            self.emit("values", self.visible_values())
            return
        if isinstance(input, Command):
            self._start_command(input, ckpt)
            return
        writes = self.checked_writes(INPUT_NODE, input)
        self.schema.check_complete("input", {**self.values, **dict(writes)})
        start = self.new_task(START)
        self.tasks = [start]
        self.outcomes, self.open_interrupts, self.resume_lists, self.fresh_resume = {}, {}, {}, {}
        self.at_breakpoint = False
        if ckpt is not None:
            self.step += 1
        self.save("input", set(self.values) if ckpt is None else set())
        self.record(start, TaskOutcome(writes=writes), save=True)

    def _start_command(self, cmd: Command[Any], ckpt: Checkpoint | None) -> None:
        if cmd.resume is not None:
            if self.saver is None:
                raise CheckpointError(
                    "Command(resume=...) continues a paused run, which needs a checkpointer: "
                    "compile(checkpointer=InMemorySaver()) and pass the same thread_id"
                )
            if ckpt is None:
                raise EmptyInputError(f"Command(resume=...) given, but thread {self.thread_id!r} has no checkpoint")
            self._take_resume(cmd.resume)
            self.skip_breakpoint = self.at_breakpoint
            self.emit("values", self.visible_values())
        if cmd.update is None and not cmd.goto:
            return
        writes = self.checked_writes(INPUT_NODE, cmd.update)
        changed = self.apply([(INPUT_NODE, writes)])
        if cmd.goto:
            self.tasks = self.plan([], extra=[(INPUT_NODE, list(cmd.goto_list()))])
            self.outcomes, self.open_interrupts = {}, {}
        self.step += 1
        self.save("input", changed)
        self.carry_outcomes()

    def checked_writes(self, node: str, update: Any) -> list[tuple[str, Any]]:
        """What a node (or the caller) wrote, normalised and validated against the schema."""
        items = self.schema.update_to_dict(node, update).items()
        return [(k, self.schema.check_write(node, k, v, self.values)) for k, v in items]

    def _take_resume(self, resume: Any) -> None:
        if not self.open_interrupts:
            raise GraphError(f"Command(resume=...) given, but no interrupt is pending on thread {self.thread_id!r}")
        by_id = {i.id: tid for tid, out in self.open_interrupts.items() for i in out.interrupts}
        targets: list[tuple[str, Any]]
        if isinstance(resume, Mapping) and resume and all(k in by_id for k in resume):
            per_task: dict[str, dict[str, Any]] = {}
            for iid, value in resume.items():
                per_task.setdefault(by_id[iid], {})[iid] = value
            # a task with one open interrupt gets the value; a subgraph task with several gets the id mapping
            targets = [
                (tid, next(iter(vals.values())) if len(self.open_interrupts[tid].interrupts) == 1 else vals)
                for tid, vals in per_task.items()
            ]
        elif len(self.open_interrupts) == 1:
            targets = [(next(iter(self.open_interrupts)), resume)]
        else:
            raise GraphError(
                f"{len(by_id)} interrupts are pending (ids {', '.join(by_id)}); resume them with "
                "Command(resume={interrupt_id: value, ...})"
            )
        for tid, value in targets:
            self.resume_lists[tid] = [*self.resume_lists.get(tid, []), value]
            self.fresh_resume[tid] = value
            # saved at once: an answer survives a crash or an error of the node after it resumes
            pending = self.open_interrupts[tid]
            self._put(tid, TaskOutcome(interrupts=pending.interrupts, resume=self.resume_lists[tid]))

    def new_id(self) -> str:
        """A task or checkpoint id: unique per run (random prefix) and cheap (a counter)."""
        self._seq += 1
        return f"{self._token}{self._seq:06x}"

    def new_task(self, node: str, *, push: bool = False, arg: Any = None) -> TaskSpec:
        return TaskSpec(self.new_id(), node, push, arg)

    # --- supersteps ---
    def _hits(self, names: frozenset[str], nodes: Iterable[str]) -> bool:
        return bool(names) and any(n != START and (n in names or "*" in names) for n in nodes)

    def begin_step(self) -> list[TaskSpec] | None:
        """The tasks to execute now, or None when the run is finished or paused."""
        if self.stopped or not self.tasks:
            return None
        if self.steps_run >= self.limit:
            raise self._recursion_error()
        if not self.skip_breakpoint and self._hits(self.graph.interrupt_before, (t.node for t in self.tasks)):
            # Reached only when a run starts at tasks planned elsewhere (a fork); end_step stops before these.
            self.stopped = self.at_breakpoint = True
            self.save("loop", set())
            self.emit("updates", {INTERRUPT_KEY: ()})
            return None
        self.skip_breakpoint = False
        self.at_breakpoint = False
        todo = [t for t in self.tasks if t.id not in self.outcomes]
        if "debug" in self.modes:
            for t in todo:
                self.emit("debug", self._debug("task", {"id": t.id, "name": t.node, "input": t.arg}))
        return todo

    def _put(self, task_id: str, outcome: TaskOutcome) -> None:
        if self.saver is not None and self.checkpoint_id:
            assert self.thread_id is not None
            self.saver.put_outcome(self.thread_id, self.ns, self.checkpoint_id, task_id, outcome)

    def record(self, task: TaskSpec, outcome: TaskOutcome, *, save: bool = False) -> None:
        """Keep a task's outcome; in a step of several tasks, or when interrupted, save it at once."""
        if outcome.interrupted:
            self.open_interrupts[task.id] = outcome
        else:
            self.outcomes[task.id] = outcome
            self.open_interrupts.pop(task.id, None)
        if save or len(self.tasks) > 1 or outcome.interrupted:
            self._put(task.id, outcome)
        if "debug" in self.modes and task.node != START:
            payload = {"id": task.id, "name": task.node, "result": outcome.writes, "interrupts": outcome.interrupts}
            self.emit("debug", self._debug("task_result", payload))

    def record_error(self, task: TaskSpec, exc: BaseException) -> None:
        resume = self.resume_lists.get(task.id, [])
        self._put(task.id, TaskOutcome(error=f"{type(exc).__name__}: {exc}", resume=resume))

    def carry_outcomes(self) -> None:
        """Save the current step's finished and paused outcomes under the newest checkpoint (after an edit)."""
        for tid, out in [*self.outcomes.items(), *self.open_interrupts.items()]:
            if out.interrupted and tid in self.resume_lists:
                out = TaskOutcome(interrupts=out.interrupts, resume=self.resume_lists[tid])
            self._put(tid, out)

    def end_step(self) -> None:
        """The barrier: apply all writes in task order, pick the next tasks, save a checkpoint."""
        if self.open_interrupts:
            opened = self.open_interrupts
            self.interrupts = [i for t in self.tasks if t.id in opened for i in opened[t.id].interrupts]
            self.stopped = True
            if "updates" in self.modes:
                for t in self.tasks:
                    if t.id in self.outcomes and t.node != START:
                        self.emit("updates", {t.node: dict(self.outcomes[t.id].writes) or None})
            self.emit("updates", {INTERRUPT_KEY: tuple(self.interrupts)})
            if "values" in self.modes:
                self.emit("values", {**self.visible_values(), INTERRUPT_KEY: tuple(self.interrupts)})
            return
        done = [(t, self.outcomes[t.id]) for t in self.tasks]
        changed = self.apply([(t.node, o.writes) for t, o in done])
        if "updates" in self.modes:
            for t, o in done:
                if t.node != START:
                    self.emit("updates", {t.node: dict(o.writes) if o.writes else None})
        self.last_nodes = [t.node for t, _ in done]
        self.tasks = self.plan(done)
        self.step += 1
        self.steps_run += 1
        self.outcomes, self.open_interrupts, self.resume_lists, self.fresh_resume = {}, {}, {}, {}
        after = self._hits(self.graph.interrupt_after, self.last_nodes)
        pause = bool(self.tasks) and (after or self._hits(self.graph.interrupt_before, (t.node for t in self.tasks)))
        self.at_breakpoint = pause
        self.save("loop", changed)
        if "values" in self.modes:
            self.emit("values", dict(self.values))
        self.stopped = pause
        if pause or after:  # after the last node there is nothing to pause, but LangGraph still says so
            self.emit("updates", {INTERRUPT_KEY: ()})

    def apply(self, writes: list[tuple[str, list[tuple[str, Any]]]]) -> set[str]:
        return merge_writes(self.schema, self.values, writes)

    def plan(
        self,
        done: list[tuple[TaskSpec, TaskOutcome]],
        extra: Iterable[tuple[str, list[str | Send]]] = (),
    ) -> list[TaskSpec]:
        """The tasks of the next superstep: edges, completed joins, routers and gotos of the finished tasks."""
        pull: set[str] = set()
        push: list[Send] = []
        view: Any = MISSING
        spec = self.spec

        def add(source: str, dest: str | Send) -> None:
            if isinstance(dest, Send):
                if dest.node not in spec.nodes:
                    raise InvalidRouteError(f"{source!r} sent to unknown node {dest.node!r} (Send)")
                push.append(dest)
            elif dest != END:
                if dest not in spec.nodes:
                    raise InvalidRouteError(
                        f"{source!r} routed to unknown node {dest!r}; known: {', '.join(spec.nodes)}"
                    )
                pull.add(dest)

        for task, outcome in done:
            node = task.node
            for target in spec.edges.get(node, ()):
                add(node, target)
            for join in spec.joins.get(node, ()):
                seen = self.joins.setdefault(join.id, [])
                if node not in seen:
                    seen.append(node)
                if all(s in seen for s in join.sources):
                    add(node, join.target)
                    del self.joins[join.id]
            for dest in outcome.goto:
                add(node, dest)
            for branch in spec.branches.get(node, ()):
                if view is MISSING:
                    view = self.schema.to_node_input(self.values)
                try:
                    kwargs = {"config": self.config} if branch.takes_config else {}
                    result = branch.router(view, **kwargs)
                    if branch.is_async:
                        result = run_sync(result)
                except Exception as exc:
                    exc.add_note(f"in router {branch.name!r} of the conditional edge from {node!r}")
                    raise
                for dest in branch.resolve(result):
                    add(node, dest)
        for source, dests in extra:
            for dest in dests:
                add(source, dest)
        # LangGraph's order: writes of a superstep are applied by node name, then Sends in the order sent
        tasks = [self.new_task(n) for n in sorted(pull)]
        tasks.extend(self.new_task(s.node, push=True, arg=s.arg) for s in push)
        return tasks

    # --- checkpoints ---
    def save(self, source: str, changed: set[str]) -> None:
        if self.saver is None:
            return
        assert self.thread_id is not None
        delta = diff_values(self._saved_lists, self.values, changed)
        for key in changed:
            value = self.values.get(key)
            if type(value) is list:
                self._saved_lists[key] = list(value)
            else:
                self._saved_lists.pop(key, None)
        ckpt = Checkpoint(
            id=self.new_id(),
            parent_id=self.checkpoint_id,
            step=self.step,
            source=source,
            created_at=time.time(),
            values=self.values,
            tasks=self.tasks,
            joins=self.joins,
            at_breakpoint=self.at_breakpoint,
            metadata={"source": source, "step": self.step, "ran": list(self.last_nodes)},
        )
        self.saver.put(self.thread_id, self.ns, ckpt, delta)
        self.checkpoint_id = ckpt.id
        if "debug" in self.modes:
            payload = {"config": self.checkpoint_config(), "values": dict(self.values), "next": self.next_nodes()}
            self.emit("debug", self._debug("checkpoint", payload))

    def checkpoint_config(self) -> dict[str, Any]:
        return {
            "configurable": {"thread_id": self.thread_id, "checkpoint_ns": self.ns, "checkpoint_id": self.checkpoint_id}
        }

    def next_nodes(self) -> tuple[str, ...]:
        return tuple(t.node for t in self.tasks)

    def _debug(self, kind: str, payload: dict[str, Any]) -> dict[str, Any]:
        return {"type": kind, "timestamp": iso_time(time.time()), "step": self.step + 1, "payload": payload}

    def _recursion_error(self) -> GraphRecursionError:
        last = ", ".join(self.last_nodes) or "(none)"
        nxt = ", ".join(self.next_nodes())
        msg = (
            f"recursion limit of {self.limit} supersteps reached without reaching END: the last superstep ran "
            f"{last} and {nxt} would run next. If the loop is meant to run this long, raise the limit: "
            f"invoke(..., config={{'recursion_limit': {self.limit * 10}, ...}})."
        )
        if self.saver is not None:
            msg += " The run is checkpointed: continue it with invoke(None, config) and a higher recursion_limit."
        else:
            msg += " If it is not, check the condition that should route to END."
        return GraphRecursionError(msg)


def preview(
    schema: StateSchema, values: Mapping[str, Any], tasks: list[TaskSpec], outcomes: Mapping[str, TaskOutcome]
) -> dict[str, Any]:
    """``values`` with the writes of the finished ``outcomes`` applied, on copies (the stored values stay)."""
    writes = [
        (t.node, outcomes[t.id].writes)
        for t in tasks
        if t.node != START and t.id in outcomes and outcomes[t.id].writes  # the input shows once applied
    ]
    touched = {k for _, items in writes for k, _ in items}
    shown = {k: copy.copy(v) if k in touched else v for k, v in values.items()}
    merge_writes(schema, shown, writes)
    return shown
