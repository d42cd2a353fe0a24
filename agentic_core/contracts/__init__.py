"""The contracts every layer shares: pydantic models with exported JSON Schemas, and the one error root.

This package imports nothing of the project and nothing heavy (no jsbsim, scipy or pymavlink), so ``flight``,
``tools`` and ``evaluation`` may import it, and a mission or scene file can be read without the simulator.

>>> from agentic_core.contracts import RunEvent
>>> RunEvent(kind="log", seq=1, summary="hello").kind
'log'
"""

from .errors import AgenticUAVError, InputError, RunFailure, report_error
from .events import EVENT_KINDS, RunEvent
from .telemetry import LandedState, TelemetrySample

__all__ = [
    "EVENT_KINDS",
    "AgenticUAVError",
    "InputError",
    "LandedState",
    "RunEvent",
    "RunFailure",
    "TelemetrySample",
    "report_error",
]
