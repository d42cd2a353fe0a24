"""Helpers shared by the tests/tools/test_executor_*.py files: the ``make_executor`` type, a one-line schema-tool
registration, a tool that fails a set number of times, an 8-thread ``hammer`` and common stage lists and arguments."""

import threading
from collections.abc import Callable
from typing import Any

from tools import ToolExecutor, ToolRegistry, ToolSpec

from .conftest import Counter

MakeExecutor = Callable[..., ToolExecutor]
BEFORE_TOOL = ["lookup:passed", "validate_args:passed", "authorize:passed"]  # the stages before the tool runs
GOTO = {"target": {"lat": 21.4, "lon": 39.8}}


def schema_tool(registry: ToolRegistry, name: str, handler: Callable[..., Any], **options: Any) -> None:
    schema = options.pop("input_schema", {"type": "object"})
    registry.register(ToolSpec.from_schema(name, handler, schema, **options))


def failing(times: int, exc: Exception, counter: Counter) -> Callable[[dict[str, Any]], str]:
    def run(args: dict[str, Any]) -> str:
        if counter.hit() <= times:
            raise exc
        return "done"

    return run


def hammer(threads: int, work: Callable[[int], None]) -> None:
    barrier = threading.Barrier(threads)

    def run(index: int) -> None:
        barrier.wait()
        work(index)

    workers = [threading.Thread(target=run, args=(i,)) for i in range(threads)]
    for worker in workers:
        worker.start()
    for worker in workers:
        worker.join(10)
