"""Missions as YAML policy graphs: the contract, validation with file:line:col messages, compilation onto the
graph runtime.

>>> from agentic_core.mission import load_mission
>>> plan = load_mission("missions/inspect_perimeter.yaml")  # doctest: +SKIP
"""

from ..contracts.failure import Failure
from .compile import Environment, MissionState, compile_mission
from .model import ACTION_TOOLS, ACTIONS, PolicyGraph, Step, mission_json_schema
from .params import initial_state
from .source import MissionError, Problem
from .validate import iter_steps, load_mission, validate_document

__all__ = [
    "ACTIONS",
    "ACTION_TOOLS",
    "Environment",
    "Failure",
    "MissionError",
    "MissionState",
    "PolicyGraph",
    "Problem",
    "Step",
    "compile_mission",
    "initial_state",
    "iter_steps",
    "load_mission",
    "mission_json_schema",
    "validate_document",
]
