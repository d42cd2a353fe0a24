"""What a run is told and what it gives back: :class:`RunSettings` (every option of ``agentic-uav run``, the
embedded defaults), the agent's identity (:data:`AGENT`), :class:`RunResult` and :class:`RunError`."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

from tools import Caller

from ..contracts import InputError
from ..contracts.faults import FaultText
from .detector_choice import parse_detector
from .report import RunSummary, TrackPoint

AGENT = Caller(
    id="agent",
    scopes=frozenset(
        {"flight:command", "flight:payload", "flight:read", "alerts:send", "weather:read", "incidents:read"}
        | {"incidents:write", "perception:read"}
    ),
)
"""The mission's caller: every scope the built-in, flight and perception tools ask for."""

DEFAULT_GCS = "127.0.0.1:14550"
"""Where ground stations listen (QGroundControl, MAVProxy), as for PX4 SITL."""
GCS_ENV = "AGENTIC_UAV_GCS"


def default_gcs() -> str:
    """The ground-station address when none is given: ``$AGENTIC_UAV_GCS``, else :data:`DEFAULT_GCS`."""
    return os.environ.get(GCS_ENV, DEFAULT_GCS)


def parse_gcs(text: str) -> tuple[str, int] | None:
    """``HOST:PORT`` as an address, ``none`` (or ``off``) as None; :class:`ValueError` for anything else.

    >>> parse_gcs("127.0.0.1:14550"), parse_gcs("none")
    (('127.0.0.1', 14550), None)
    """
    if text.strip().lower() in ("none", "off"):
        return None
    host, sep, port = text.strip().rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise ValueError(f"expected HOST:PORT or none, not {text!r}")
    return host, int(port)


class RunSettings(BaseModel):
    """Everything a run is told; the defaults are the embedded ones (rules reasoner, simulated vehicle)."""

    model_config = ConfigDict(extra="forbid")

    mission: Path
    scene: Path | None = Field(default=None, description="default: scenes/<mission name>.yaml when it exists")
    reasoner: str = "rules"
    llm: str | None = None
    speed: float | None = Field(default=None, description="times real time; None: as fast as it goes")
    approval: Literal["approve", "decline", "ask"] = Field(
        default="approve",
        description="steps marked approval: answered by this policy (headless), or 'ask' the operator, pausing the "
        "mission graph until they answer",
    )
    approval_timeout_s: float = Field(default=120.0, gt=0, description="'ask': no answer in this long declines")
    runs_dir: Path = Path("runs")
    params: dict[str, str] = Field(default_factory=dict)
    seed: int = 0
    camera_hz: float = Field(default=30.0, gt=0, le=120, description="frames per second of the simulated camera")
    render: bool = Field(default=False, description="the simulated camera renders 640×480 pixels (flight.sim.render)")
    gains: Path | None = Field(
        default=None, description="the simulated vehicle's position-controller gains (tune.json of eval tune)"
    )
    max_wall_s: float = Field(default=900.0, gt=0, description="give up (and land) after this much wall time")
    connect: str | None = Field(
        default=None, description="fly the vehicle at this MAVLink address (udp://HOST:PORT) instead of the simulator"
    )
    tools: list[str] = Field(
        default_factory=list, description="more tools: modules, .py files or YAML/JSON files of HTTP endpoints"
    )
    signing_key: Path | None = Field(
        default=None, description="with connect: the MAVLink 2 signing key file (32 raw bytes or 64 hex digits)"
    )
    telemetry_hz: float = Field(default=10.0, gt=0, le=100, description="rate of telemetry.jsonl, Hz of vehicle time")
    faults: list[FaultText] = Field(
        default_factory=list, description="failures to inject (--fault), beside the scene's own faults: list"
    )
    memory: Path | None = Field(
        default=None, description="the fleet's memory (a SQLite file): recall what earlier runs found, record this one"
    )
    detector: str = Field(default="sim", description="sim, ours or onnx:PATH (the last two render the camera)")
    gcs: str = Field(
        default_factory=default_gcs,
        validate_default=True,
        description="the ground station the simulated vehicle also streams to (HOST:PORT), or none",
    )

    @field_validator("gcs")
    @classmethod
    def _gcs_is_an_address(cls, value: str) -> str:
        try:
            parse_gcs(value)
        except ValueError as exc:
            raise ValueError(f"{exc} (from --gcs or ${GCS_ENV})") from None
        return value

    @field_validator("detector")
    @classmethod
    def _known_detector(cls, value: str) -> str:
        return parse_detector(value)

    @property
    def gcs_address(self) -> tuple[str, int] | None:
        """:attr:`gcs` as an address (None: no ground-station stream)."""
        return parse_gcs(self.gcs)


class RunError(InputError):
    """A run that cannot start: a bad mission, scene or option. The message names the file and field."""


@dataclass
class RunResult:
    run_id: str
    run_dir: Path
    report: Path
    summary: RunSummary
    final_state: dict[str, Any] = field(default_factory=dict)
    track: list[TrackPoint] = field(default_factory=list)


def default_scene(mission: Path) -> Path | None:
    """``scenes/<mission stem>.yaml`` beside the mission's folder or in the working directory, if it exists."""
    for root in (mission.resolve().parent.parent, Path.cwd()):
        candidate = root / "scenes" / f"{mission.stem}.yaml"
        if candidate.is_file():
            return candidate
    return None


__all__ = ["AGENT", "DEFAULT_GCS", "RunError", "RunResult", "RunSettings", "default_gcs", "default_scene", "parse_gcs"]
