"""Checkpoint records and the saver interface shared by the in-memory and SQLite savers.

A checkpoint stores only the keys that changed in its superstep, and a list that grew by appending (the
``Annotated[list, operator.add]`` pattern) stores only the new items. Reading walks the parent chain. So storage
grows linearly with the number of steps, where a full copy per checkpoint would grow quadratically.
"""

from __future__ import annotations

import itertools
import threading
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

from ..errors import CheckpointError
from ..types import Interrupt, Send

FULL, APPEND = "full", "append"


class Serializer(Protocol):
    """Turns a checkpoint body into bytes and back."""

    def dumps(self, obj: Any) -> bytes: ...
    def loads(self, data: bytes) -> Any: ...


class PickleSerializer:
    """The default serializer. Checkpoint stores are trusted local files: never load one from a stranger."""

    def __init__(self) -> None:
        import pickle  # on first use, to keep ``import agentic_core.graph`` light

        self._dumps = pickle.dumps
        self._loads = pickle.loads
        self._protocol = pickle.HIGHEST_PROTOCOL

    def dumps(self, obj: Any) -> bytes:
        data: bytes = self._dumps(obj, protocol=self._protocol)
        return data

    def loads(self, data: bytes) -> Any:
        return self._loads(data)


@dataclass(slots=True)
class TaskSpec:
    """A task scheduled for a superstep: a node, and for a ``Send`` the argument it gets instead of the state."""

    id: str
    node: str
    push: bool = False
    arg: Any = None


@dataclass(slots=True)
class TaskOutcome:
    """What a finished (or interrupted) task left behind: its validated writes and where it routes next."""

    writes: list[tuple[str, Any]] = field(default_factory=list)
    goto: list[str | Send] = field(default_factory=list)
    interrupts: tuple[Interrupt, ...] = ()
    resume: list[Any] = field(default_factory=list)
    error: str | None = None

    @property
    def interrupted(self) -> bool:
        return bool(self.interrupts)


@dataclass(slots=True)
class Checkpoint:
    """A materialised checkpoint: full values, the tasks still to run, join barriers, pending task outcomes."""

    id: str
    parent_id: str | None
    step: int
    source: str
    created_at: float  # seconds since the epoch; shown as ISO 8601 in a StateSnapshot
    values: dict[str, Any]
    tasks: list[TaskSpec]
    joins: dict[str, list[str]] = field(default_factory=dict)
    at_breakpoint: bool = False
    metadata: dict[str, Any] = field(default_factory=dict)
    outcomes: dict[str, TaskOutcome] = field(default_factory=dict)


@dataclass(slots=True)
class CheckpointRow:
    """A checkpoint as stored: the changed keys only (``delta``), in serialized form."""

    id: str
    parent_id: str | None
    step: int
    source: str
    created_at: float
    body: bytes


def iso_time(seconds: float) -> str:
    from datetime import UTC, datetime

    return datetime.fromtimestamp(seconds, UTC).isoformat()


def diff_values(saved: Mapping[str, Any], new: Mapping[str, Any], changed: set[str]) -> dict[str, tuple[Any, ...]]:
    """The delta of ``changed`` keys against what was saved last; appended lists store only their new items.

    ``saved`` holds a copy of each list as last saved, so a reducer that appends in place is still seen right.
    """
    delta: dict[str, tuple[Any, ...]] = {}
    for key in changed:
        value, before = new[key], saved.get(key)
        if (
            type(value) is list
            and type(before) is list
            and 0 < len(before) <= len(value)
            and value[: len(before)] == before
        ):
            delta[key] = (APPEND, value[len(before) :])
        else:
            delta[key] = (FULL, value)
    return delta


class BaseCheckpointSaver:
    """Stores checkpoints per ``(thread_id, checkpoint_ns)``; subclasses provide the storage primitives."""

    def __init__(self, serde: Serializer | None = None) -> None:
        self.serde: Serializer = serde or PickleSerializer()
        self._lock = threading.RLock()

    # --- storage primitives (subclasses) ---
    def _put_row(self, thread_id: str, ns: str, row: CheckpointRow) -> None:
        raise NotImplementedError

    def _rows(self, thread_id: str, ns: str) -> list[CheckpointRow]:
        """All rows of a thread and namespace, oldest first."""
        raise NotImplementedError

    def _put_outcome(self, thread_id: str, ns: str, checkpoint_id: str, task_id: str, body: bytes) -> None:
        raise NotImplementedError

    def _outcomes(self, thread_id: str, ns: str, checkpoint_id: str) -> dict[str, bytes]:
        raise NotImplementedError

    def delete_thread(self, thread_id: str) -> None:
        """Forget every checkpoint of a thread, in every namespace."""
        raise NotImplementedError

    # --- the interface the runtime uses ---
    def put(
        self,
        thread_id: str,
        ns: str,
        checkpoint: Checkpoint,
        delta: Mapping[str, tuple[Any, ...]],
    ) -> None:
        body = {
            "delta": dict(delta),
            "tasks": [(t.id, t.node, t.push, t.arg) for t in checkpoint.tasks],  # tuples pickle fastest
            "joins": checkpoint.joins,
            "at_breakpoint": checkpoint.at_breakpoint,
            "metadata": checkpoint.metadata,
        }
        row = CheckpointRow(
            checkpoint.id,
            checkpoint.parent_id,
            checkpoint.step,
            checkpoint.source,
            checkpoint.created_at,
            self.serde.dumps(body),
        )
        with self._lock:
            self._put_row(thread_id, ns, row)

    def put_outcome(self, thread_id: str, ns: str, checkpoint_id: str, task_id: str, outcome: TaskOutcome) -> None:
        with self._lock:
            self._put_outcome(thread_id, ns, checkpoint_id, task_id, self.serde.dumps(outcome))

    def get(self, thread_id: str, ns: str = "", checkpoint_id: str | None = None) -> Checkpoint | None:
        """The checkpoint ``checkpoint_id`` (default: the newest) with its values rebuilt from the deltas."""
        with self._lock:
            rows = self._rows(thread_id, ns)
        if not rows:
            return None
        reader = _ChainReader(self.serde, rows)
        if checkpoint_id is None:
            target = rows[-1]
        elif checkpoint_id in reader.by_id:
            target = reader.by_id[checkpoint_id]
        else:
            raise CheckpointError(f"thread {thread_id!r} has no checkpoint {checkpoint_id!r}")
        return self._materialise(thread_id, ns, target, reader.values(target), reader.body(target))

    def list(self, thread_id: str, ns: str = "") -> Iterator[Checkpoint]:
        """Every checkpoint of a thread, newest first (forks included); each is rebuilt only when reached."""
        with self._lock:
            rows = self._rows(thread_id, ns)
        reader = _ChainReader(self.serde, rows)
        for row in reversed(rows):
            yield self._materialise(thread_id, ns, row, reader.values(row), reader.body(row))

    # --- helpers ---
    def _materialise(
        self,
        thread_id: str,
        ns: str,
        row: CheckpointRow,
        values: dict[str, Any],
        body: dict[str, Any] | None = None,
    ) -> Checkpoint:
        body = body if body is not None else self.serde.loads(row.body)
        with self._lock:
            raw = self._outcomes(thread_id, ns, row.id)
        outcomes = {tid: self.serde.loads(b) for tid, b in raw.items()}
        return Checkpoint(
            id=row.id,
            parent_id=row.parent_id,
            step=row.step,
            source=row.source,
            created_at=row.created_at,
            values=values,
            tasks=[TaskSpec(*t) for t in body["tasks"]],
            joins=body["joins"],
            at_breakpoint=body["at_breakpoint"],
            metadata=body["metadata"],
            outcomes=outcomes,
        )


def values_from_deltas(deltas_newest_first: Iterable[Mapping[str, tuple[Any, ...]]]) -> dict[str, Any]:
    """Rebuild values from a chain of deltas, newest first: each key stops at its newest full record, and the
    items appended since are joined once (linear in the chain, however long the lists grow)."""
    values: dict[str, Any] = {}
    appended: dict[str, list[list[Any]]] = {}
    for delta in deltas_newest_first:
        for key, record in delta.items():
            if key in values:
                continue
            if record[0] == APPEND:
                appended.setdefault(key, []).append(record[1])
                continue
            parts = appended.pop(key, None)
            values[key] = [*record[1], *itertools.chain.from_iterable(reversed(parts))] if parts else record[1]
    for key, parts in appended.items():
        values[key] = list(itertools.chain.from_iterable(reversed(parts)))
    return values


class _ChainReader:
    """Rows of one thread, with bodies unpickled once each, rebuilding any checkpoint along its parent chain."""

    def __init__(self, serde: Serializer, rows: list[CheckpointRow]) -> None:
        self.serde = serde
        self.by_id = {r.id: r for r in rows}
        self._bodies: dict[str, dict[str, Any]] = {}

    def body(self, row: CheckpointRow) -> dict[str, Any]:
        body = self._bodies.get(row.id)
        if body is None:
            body = self._bodies[row.id] = self.serde.loads(row.body)
        return body

    def values(self, row: CheckpointRow) -> dict[str, Any]:
        def chain() -> Iterator[Mapping[str, tuple[Any, ...]]]:
            link: CheckpointRow | None = row
            while link is not None:
                yield self.body(link)["delta"]
                link = self.by_id.get(link.parent_id) if link.parent_id else None

        return values_from_deltas(chain())
