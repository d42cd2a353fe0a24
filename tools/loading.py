"""Building the registry users get: the built-in tools, their own tools, and plugins.

``--tools`` names a Python module (``mypkg.tools``), a ``.py`` file, or a YAML/JSON file of HTTP endpoint
descriptions; installed packages add tools through the ``agentic_uavs.tools`` entry-point group, whose entries
are modules of ``@tool`` functions or ``register(registry)`` callables.
"""

from __future__ import annotations

import importlib
import importlib.util
import inspect
import sys
from collections.abc import Collection, Iterable
from dataclasses import replace
from importlib.metadata import entry_points
from pathlib import Path
from types import ModuleType
from typing import Any

from agentic_core.contracts.problems import LocatedProblem

from .errors import ToolDefinitionError
from .registry import ToolRegistry

ENTRY_POINT_GROUP = "agentic_uavs.tools"
HTTP_SUFFIXES = (".yaml", ".yml", ".json")


def _import_file(path: Path) -> ModuleType:
    name = f"agentic_uavs_user_tools_{abs(hash(path.resolve()))}"
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise ToolDefinitionError([LocatedProblem(str(path), None, None, "cannot be imported as a Python module")])
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def _register_object(registry: ToolRegistry, value: Any, origin: str) -> list[str]:
    if isinstance(value, ModuleType):
        names = registry.register_module(value)
        if not names and callable(getattr(value, "register", None)):
            return _register_object(registry, value.register, origin)
        if not names:
            message = "defines no @tool functions and no register(registry) function"
            raise ToolDefinitionError([LocatedProblem(origin, None, None, message)])
        return names
    if callable(value):
        before = set(registry.names())
        value(registry)
        return sorted(set(registry.names()) - before)
    message = "is neither a module of tools nor a register(registry) callable"
    raise ToolDefinitionError([LocatedProblem(origin, None, None, message)])


def load_tools(registry: ToolRegistry, source: str) -> list[str]:
    """Register the tools ``source`` names (a module, a ``.py`` file or an HTTP description file). Whatever goes
    wrong (a syntax error, an exception at import, a bad tool definition) is a :class:`ToolDefinitionError` that
    names the source."""
    try:
        return _load(registry, source)
    except ToolDefinitionError as exc:
        raise ToolDefinitionError([p if p.file else replace(p, file=source) for p in exc.problems]) from None
    except SyntaxError as exc:
        line = exc.lineno if exc.lineno and exc.lineno > 0 else None
        col = exc.offset if line is not None and exc.offset and exc.offset > 0 else None
        raise ToolDefinitionError([LocatedProblem(exc.filename or source, line, col, exc.msg)]) from None
    except Exception as exc:
        message = f"cannot load it: {type(exc).__name__}: {exc}"
        raise ToolDefinitionError([LocatedProblem(source, None, None, message)]) from None


def _load(registry: ToolRegistry, source: str) -> list[str]:
    if not source.strip():
        raise ToolDefinitionError("an empty --tools source")
    path = Path(source)
    if path.suffix.lower() in HTTP_SUFFIXES:
        if not path.is_file():
            raise ToolDefinitionError(f"{source}: no such file")
        from .http_endpoint import register_http_tools

        return register_http_tools(registry, path)
    if path.suffix == ".py" or "/" in source or source.startswith("."):
        if not path.is_file() or path.suffix != ".py":
            raise ToolDefinitionError(f"{source}: no such file (a module name, a .py file or a .yaml/.json file)")
        module = _import_file(path)
    else:
        try:
            module = importlib.import_module(source)
        except ModuleNotFoundError as exc:
            raise ToolDefinitionError(f"cannot import it ({exc})") from None
    return _register_object(registry, module, source)


def load_entry_points(registry: ToolRegistry) -> list[str]:
    """Register the tools installed packages declare under ``agentic_uavs.tools``."""
    names: list[str] = []
    for point in entry_points(group=ENTRY_POINT_GROUP):
        try:
            value = point.load()
        except Exception as exc:
            raise ToolDefinitionError(f"entry point {point.name!r} ({point.value}): cannot load it ({exc})") from None
        names += _register_object(registry, value, f"entry point {point.name!r}")
    return names


def build_registry(
    sources: Iterable[str] = (),
    *,
    builtins: bool = True,
    plugins: bool = True,
    config: Any = None,
    reserved: Collection[str] = (),
) -> ToolRegistry:
    """The registry the command line and the mission runner use: built-ins (configured from the environment
    unless ``config`` is given), installed plugins, then ``sources`` in order. A plugin or source defining a tool
    named in ``reserved`` (the tools the caller registers itself afterwards) is a :class:`ToolDefinitionError`.

    >>> registry = build_registry(plugins=False)
    >>> "weather.get_forecast" in registry and "alerts.notify" in registry
    True
    """
    registry = ToolRegistry()
    if builtins:
        from .builtin import register_builtins

        register_builtins(registry, config)
    if plugins:
        _refuse_reserved(registry, load_entry_points(registry), f"an installed plugin ({ENTRY_POINT_GROUP})", reserved)
    for source in sources:
        _refuse_reserved(registry, load_tools(registry, source), source, reserved)
    return registry


def _refuse_reserved(registry: ToolRegistry, names: Iterable[str], origin: str, reserved: Collection[str]) -> None:
    """A :class:`ToolDefinitionError` for each tool ``origin`` defined under a name the caller registers itself
    (a run's ``flight.*``), naming the file and the line of the tool's function where it can be found."""
    problems = []
    for name in names:
        if name in reserved:
            file, line = _defined_at(registry.get(name).handler, origin)
            why = f"tool {name!r} clashes with the built-in tool {name}, which the run registers itself; rename it"
            problems.append(LocatedProblem(file, line, None, why))
    if problems:
        raise ToolDefinitionError(problems)


def _defined_at(handler: Any, origin: str) -> tuple[str, int | None]:
    """Where a tool's function is written: ``origin`` and, when the function (the handler, or the function a
    ``@tool`` handler wraps) is in that file, its ``def`` line."""
    if Path(origin).suffix != ".py":
        return origin, None
    file = Path(origin).resolve()
    cells = [_contents(cell) for cell in getattr(handler, "__closure__", None) or ()]
    for candidate in (handler, *cells):
        code = getattr(inspect.unwrap(candidate), "__code__", None) if callable(candidate) else None
        if code is not None and Path(code.co_filename).resolve() == file:
            return origin, int(code.co_firstlineno)
    return origin, None


def _contents(cell: Any) -> Any:
    try:
        return cell.cell_contents
    except ValueError:  # a cell not yet filled
        return None
