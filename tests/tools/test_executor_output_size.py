"""The bound on a tool's output: an answer over ``max_output_bytes`` of JSON, or one that is not JSON data, is an
error result naming the tool and the size, found without serialising it, and the executor's memory stays a small
multiple of what it keeps (tracemalloc peaks, not RSS)."""

import asyncio
import itertools
import json
import tracemalloc
from collections.abc import Callable, Iterator
from typing import Any

import pytest

from agentic_core.contracts.errors import InputError
from tools import MemoryAuditLog, ToolExecutor, ToolRegistry
from tools.output_size import DEFAULT_MAX_OUTPUT_BYTES, MAX_OUTPUT_ENV

from .conftest import Counter, registered, stage
from .executor_fixtures import MakeExecutor, schema_tool

LIMIT = 4096


def compact(value: Any) -> int:
    return len(json.dumps(value, separators=(",", ":"), ensure_ascii=False).encode())


def answering(registry: ToolRegistry, value: Callable[[], Any], name: str = "svc.answer", **options: Any) -> None:
    """A schema tool (its output passed through untouched) answering ``value()``."""
    schema_tool(registry, name, lambda args: value(), **options)


def peak_of(call: Callable[[], Any]) -> tuple[int, Any]:
    """The tracemalloc peak, in bytes, of ``call()`` over what was allocated before it, and its result."""
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        base = tracemalloc.get_traced_memory()[0]
        result = call()
        return tracemalloc.get_traced_memory()[1] - base, result
    finally:
        tracemalloc.stop()


# the bound ----------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("padding", [-1, 0])
def test_an_output_just_under_the_bound_is_kept(
    registry: ToolRegistry, make_executor: MakeExecutor, padding: int
) -> None:
    overhead = compact({"blob": ""})
    value = {"blob": "A" * (LIMIT - overhead + padding - 1)}  # its JSON: one or two bytes under the limit
    answering(registry, lambda: value)
    result = make_executor(registry, max_output_bytes=LIMIT).call("svc.answer", {})
    assert compact(value) < LIMIT
    assert result.ok and result.output == value


@pytest.mark.parametrize("excess", [1, 2, 1000])
def test_an_output_just_over_the_bound_is_an_error_naming_the_tool_and_size(
    registry: ToolRegistry, make_executor: MakeExecutor, excess: int
) -> None:
    value = {"blob": "A" * (LIMIT - compact({"blob": ""}) + excess)}
    runs = Counter()
    answering(registry, lambda: (runs.hit(), value)[1])
    audit = MemoryAuditLog()
    result = make_executor(registry, max_output_bytes=LIMIT, audit=audit).call("svc.answer", {})
    assert result.status == "error" and result.output is None and runs.runs == 1
    assert result.error is not None and "'svc.answer'" in result.error and f"limit of {LIMIT}" in result.error
    counted = int(result.error.split("too large: ")[1].split(" ")[0])
    assert compact(value) <= counted <= compact(value) + 1
    assert stage(result, "validate_output").outcome == "failed"
    assert [r.status for r in audit.records] == ["error"] and audit.records[0].output is None


def test_a_non_ascii_string_counts_its_utf8_bytes(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    text = "é" * (LIMIT // 2)  # LIMIT // 2 characters, LIMIT bytes of UTF-8
    answering(registry, lambda: text)
    result = make_executor(registry, max_output_bytes=LIMIT).call("svc.answer", {})
    assert result.status == "error" and result.error is not None and "too large" in result.error
    answering(registry, lambda: text[: LIMIT // 4], name="svc.half")
    assert make_executor(registry, max_output_bytes=LIMIT).call("svc.half", {}).ok


def test_a_function_tool_over_the_bound_is_refused_before_its_output_is_converted(
    registry: ToolRegistry, make_executor: MakeExecutor
) -> None:
    @registered(registry, name="big.blob")
    def blob(x: int) -> dict[str, str]:
        return {"blob": "A" * (3 * LIMIT)}

    result = make_executor(registry, max_output_bytes=LIMIT).call("big.blob", {"x": 1})
    assert result.status == "error" and result.error is not None
    assert result.error.startswith("the output of 'big.blob' is too large: ")


def test_an_async_tool_over_the_bound_through_acall(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    @registered(registry, name="big.async")
    async def blob() -> list[str]:
        return ["x" * 100] * LIMIT

    result = asyncio.run(make_executor(registry, max_output_bytes=LIMIT).acall("big.async", {}))
    assert result.status == "error" and result.error is not None and "'big.async' is too large" in result.error


def test_the_default_bound_is_one_mebibyte(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    answering(registry, lambda: "A" * DEFAULT_MAX_OUTPUT_BYTES)
    executor = make_executor(registry)
    assert executor.max_output_bytes == DEFAULT_MAX_OUTPUT_BYTES == 1024 * 1024
    result = executor.call("svc.answer", {})
    assert result.status == "error" and result.error is not None and "limit of 1048576" in result.error


def test_the_bound_is_read_from_the_environment(
    registry: ToolRegistry, make_executor: MakeExecutor, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv(MAX_OUTPUT_ENV, "100")
    answering(registry, lambda: "A" * 200)
    result = make_executor(registry).call("svc.answer", {})
    assert result.status == "error" and result.error is not None and "limit of 100" in result.error
    assert make_executor(registry, max_output_bytes=1000).call("svc.answer", {}).ok  # the argument wins


@pytest.mark.parametrize("text", ["0", "-5", "lots", "1.5", " "])
def test_a_bad_bound_in_the_environment_is_an_input_error(
    registry: ToolRegistry, monkeypatch: pytest.MonkeyPatch, text: str
) -> None:
    monkeypatch.setenv(MAX_OUTPUT_ENV, text)
    if not text.strip():  # blank: unset
        ToolExecutor(registry).close()
        return
    with pytest.raises(InputError, match=MAX_OUTPUT_ENV):
        ToolExecutor(registry)


@pytest.mark.parametrize("bound", [0, -1, 1.5, True, "1024"])
def test_a_bad_bound_argument_is_refused(registry: ToolRegistry, bound: Any) -> None:
    with pytest.raises(ValueError, match="max_output_bytes"):
        ToolExecutor(registry, max_output_bytes=bound)


# hostile outputs ----------------------------------------------------------------------------------------------------
def test_a_huge_nested_list_is_refused_after_about_the_limit_of_steps(
    registry: ToolRegistry, make_executor: MakeExecutor
) -> None:
    row = [0.5] * 10_000
    value = [row] * 10_000  # a hundred million numbers to a serialiser, a few kilobytes to build
    answering(registry, lambda: value)
    peak, result = peak_of(lambda: make_executor(registry, max_output_bytes=LIMIT).call("svc.answer", {}))
    assert result.status == "error" and "too large" in result.error
    assert peak < 256 * 1024  # nothing proportional to the hundred million


def test_a_generator_is_not_run(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    pulled = Counter()

    def endless() -> Iterator[int]:
        for n in itertools.count():
            pulled.hit()
            yield n

    answering(registry, lambda: {"rows": endless()})
    result = make_executor(registry).call("svc.answer", {})
    assert result.error == "the output of 'svc.answer' is not JSON data: $.rows is a generator"
    assert pulled.runs == 0


def test_an_iterator_from_a_function_tool_is_not_consumed(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    @registered(registry, name="svc.rows")
    def rows() -> list[int]:
        return itertools.count()  # type: ignore[return-value]

    result = make_executor(registry).call("svc.rows", {})  # pydantic would read an endless iterator for a list
    assert result.status == "error" and result.error == "the output of 'svc.rows' is not JSON data: $ is a count"


class Loud:
    """An object whose repr and str would be huge; both are counted, so a call is seen."""

    def __init__(self) -> None:
        self.calls = Counter()

    def __repr__(self) -> str:
        self.calls.hit()
        return "x" * 50_000_000

    __str__ = __repr__


def test_an_object_with_a_huge_repr_is_refused_without_calling_it(
    registry: ToolRegistry, make_executor: MakeExecutor
) -> None:
    loud = Loud()
    answering(registry, lambda: {"items": [1, loud]})
    audit = MemoryAuditLog()
    peak, result = peak_of(lambda: make_executor(registry, audit=audit).call("svc.answer", {}))
    assert result.status == "error" and result.error is not None
    assert result.error.endswith("is not JSON data: $.items[1] is a Loud")
    assert loud.calls.runs == 0 and peak < 1024 * 1024
    assert json.dumps(audit.records[0].model_dump(), default=repr)  # the record is written without it


@pytest.mark.parametrize("size", [10, 3 * LIMIT])
def test_bytes_are_counted_by_their_length(registry: ToolRegistry, make_executor: MakeExecutor, size: int) -> None:
    answering(registry, lambda: {"data": b"\x00" * size})
    result = make_executor(registry, max_output_bytes=LIMIT).call("svc.answer", {})
    assert result.ok == (size < LIMIT)
    if not result.ok:
        assert result.error is not None and f"too large: {size + compact({'data': ''}) + 1}" in result.error


def test_a_circular_output_is_refused(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    loop: dict[str, Any] = {"name": "a"}
    loop["self"] = [loop]
    answering(registry, lambda: loop)
    result = make_executor(registry).call("svc.answer", {})
    assert result.error == "the output of 'svc.answer' is not JSON data: $.self[0] contains itself"


def test_a_shared_but_acyclic_output_is_fine(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    leaf = {"n": 1}
    answering(registry, lambda: {"a": leaf, "b": [leaf, leaf]})
    assert make_executor(registry).call("svc.answer", {}).ok


def test_an_output_nested_too_deep_is_refused(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    deep: list[Any] = []
    inner = deep
    for _ in range(5000):  # deeper than json.dumps or the injection guard's readers could recurse
        inner.append([])
        inner = inner[0]
    answering(registry, lambda: deep)
    result = make_executor(registry).call("svc.answer", {})
    assert result.status == "error" and result.error is not None
    assert "is nested more than 100 levels deep at $[0][0]" in result.error


# memory -------------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("megabytes", [4, 40])
def test_an_over_limit_output_costs_the_executor_almost_nothing(
    registry: ToolRegistry, make_executor: MakeExecutor, megabytes: int
) -> None:
    blob = {"blob": "A" * (megabytes * 1024 * 1024)}  # made before tracing: the tool's own memory
    answering(registry, lambda: blob, side_effects=True)
    executor = make_executor(registry)
    peak, result = peak_of(lambda: executor.call("svc.answer", {}, idempotency_key="k-1"))
    assert result.status == "error" and result.error is not None
    assert f"too large: {compact(blob) + 1} bytes" in result.error
    assert peak < 256 * 1024  # not a copy, not a repr, not a JSON text: a walk


@pytest.mark.parametrize(
    "shape",
    [
        lambda n: {"blob": "A" * n},
        lambda n: {"text": ("wind 12 kt from 320, gusts 20; visibility good. " * (n // 48))},
        lambda n: {"hex": "deadbeef " * (n // 9)},
        lambda n: {"spelt": "i g n o r e " * (n // 12)},
        lambda n: [f"row {i}" for i in range(n // 12)],
        lambda n: [{"id": i, "pos": [1.5, 2.5]} for i in range(n // 30)],
    ],
    ids=["letters", "prose", "hex", "spelt-out", "list-of-str", "records"],
)
def test_an_output_under_the_bound_costs_a_small_multiple_of_its_size(
    registry: ToolRegistry, make_executor: MakeExecutor, shape: Callable[[int], Any]
) -> None:
    value = shape(900_000)
    answering(registry, lambda: value, side_effects=True)
    executor = make_executor(registry)
    peak, result = peak_of(lambda: executor.call("svc.answer", {}, idempotency_key="k-1"))
    size = compact(value)
    assert result.ok and result.output is value and 800_000 < size < 1024 * 1024
    assert peak < 32 * size, f"peak {peak} for {size} bytes of JSON"
