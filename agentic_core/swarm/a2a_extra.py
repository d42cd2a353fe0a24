"""The A2A modules' optional dependencies: when one is missing, :func:`missing` is the error that says which extra
installs it, raised at import instead of a bare ``ModuleNotFoundError``.

>>> str(missing(ModuleNotFoundError("No module named 'a2a'", name="a2a")))
"the swarm's A2A agents (agentic_core.swarm) needs a2a (No module named 'a2a'): pip install 'agentic-uavs[a2a]'"
"""

from __future__ import annotations

from agentic_core.contracts.extras import EXTRAS, MissingExtra, install_hint

EXTRA = "a2a"


def missing(exc: ImportError) -> MissingExtra:
    """The error for an A2A module whose import failed with ``exc``."""
    module = exc.name or EXTRA
    return MissingExtra(f"{EXTRAS[EXTRA]} needs {module} ({exc}): {install_hint(EXTRA)}", extra=EXTRA, module=module)


__all__ = ["EXTRA", "missing"]
