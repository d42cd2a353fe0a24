"""A swarm mission's own block (``swarm:`` in a mission file): how many UAVs, the area they split into sectors,
their roles, the altitude layers and separation they keep, and who confirms a casualty before the alert (``verify``).
Steps and triggers name who does them with ``uav:`` (a role, or ``any``); :func:`uav_problems` checks those names.

>>> plan = SwarmPlan.model_validate({"area": [{"lat": 21.41, "lon": 39.89}, {"lat": 21.42, "lon": 39.89},
...                                            {"lat": 21.42, "lon": 39.90}], "roles": {"medic": {"count": 1,
...                                            "payload": ["medkit"]}}})
>>> plan.vehicles, plan.role_of(0), plan.role_of(1), plan.payload_of(0), plan.verify.by, plan.verify.k
(4, 'medic', None, ('medkit',), 'uavs', 2)
>>> uav_problems(["any", "medic", "pilot"], plan)
["uav: 'pilot' is neither 'any' nor a role of swarm.roles (medic)"]
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, StringConstraints, model_validator

from .mission_values import MAX_POINTS

RoleName = Annotated[str, StringConstraints(pattern=r"^[A-Za-z_][A-Za-z0-9_]*$", max_length=64)]
ANY = "any"
"""The ``uav:`` of a step or trigger any UAV may carry out (the swarm decides which at run time)."""


class _Contract(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)


class Corner(_Contract):
    lat: float = Field(ge=-90, le=90)
    lon: float = Field(ge=-180, le=180)


class Role(_Contract):
    """A role some UAVs hold (the first ones, in the order the roles are written) and what they carry."""

    count: int = Field(default=1, ge=1, le=64)
    payload: list[Annotated[str, StringConstraints(min_length=1, max_length=64)]] = Field(default_factory=list)


class Separation(_Contract):
    """Two UAVs closer than both distances at once have lost separation."""

    horizontal_m: float = Field(default=15.0, gt=0)
    vertical_m: float = Field(default=8.0, gt=0)


class Verification(_Contract):
    """Who confirms a casualty one UAV found before the alert: other UAVs' eyes (``uavs``, k of n, the finder among
    them) or the operator (``operator``: asked on the finding UAV's control port, answered like an approval)."""

    by: Literal["uavs", "operator"] = "uavs"
    k: int = Field(default=2, ge=1, le=64, description="by: uavs — UAVs that must see the casualty (k of n)")
    timeout_s: float = Field(
        default=120.0, gt=0, le=500, description="by: operator — seconds the operator has to answer"
    )
    on_timeout: Literal["unverified", "verified"] = Field(
        default="unverified",
        description="by: operator — no answer in time: unverified (no alert) or verified (alert anyway)",
    )

    @model_validator(mode="after")
    def _fields_of_its_kind(self) -> Verification:
        wrong = {"k"} if self.by == "operator" else {"timeout_s", "on_timeout"}
        given = sorted(wrong & self.model_fields_set)
        if given:
            raise ValueError(f"{', '.join(given)} does not go with by: {self.by}")
        return self


class Heartbeat(_Contract):
    """Without the ground, the UAVs judge each other alive by signed heartbeats: one every ``period_s``, and a UAV
    silent for longer than ``timeout_s`` (both seconds of the swarm's clock) has failed; its tasks move."""

    period_s: float = Field(default=1.0, gt=0, le=60)
    timeout_s: float = Field(default=10.0, gt=0, le=600)

    @model_validator(mode="after")
    def _several_beats(self) -> Heartbeat:
        if self.timeout_s < 2 * self.period_s:
            raise ValueError(f"timeout_s {self.timeout_s:g} is under two periods ({2 * self.period_s:g} s)")
        return self


class SwarmPlan(_Contract):
    """The ``swarm:`` block of a mission flown by several UAVs (``agentic-uav swarm run``)."""

    vehicles: int = Field(default=4, ge=1, le=64, description="UAVs when --vehicles is not given")
    area: list[Corner] = Field(
        min_length=3, max_length=MAX_POINTS, description="the area the UAVs split into sectors, one per UAV"
    )
    roles: dict[RoleName, Role] = Field(default_factory=dict, description="roles, given to the first UAVs in order")
    layers_m: list[Annotated[float, Field(gt=0)]] = Field(
        default_factory=lambda: [30.0, 40.0, 50.0, 60.0],
        min_length=1,
        description="altitude layers above home; UAV i cruises in layer i modulo their number",
    )
    separation: Separation = Field(default_factory=Separation)
    verify: Verification = Field(
        default_factory=Verification,
        description="who confirms a casualty before the alert: {by: uavs, k: 2} or "
        "{by: operator, timeout_s: 120, on_timeout: unverified}",
    )
    verify_k: int | None = Field(
        default=None, ge=1, le=64, description="the older spelling of verify: {by: uavs, k: N}; not with verify"
    )
    heartbeat: Heartbeat = Field(
        default_factory=Heartbeat, description="without the ground: UAVs heard from no peer this long have failed"
    )
    pad_spacing_m: float = Field(default=20.0, gt=0, description="launch pads along east, this far apart")

    @model_validator(mode="after")
    def _names(self) -> SwarmPlan:
        if ANY in self.roles:
            raise ValueError(f"{ANY!r} cannot be a role's name: it means every UAV")
        if self.verify_k is not None:
            if "verify" in self.model_fields_set:
                raise ValueError("verify_k and verify: give verify: {by: uavs, k: N} alone")
            self.verify = Verification(by="uavs", k=self.verify_k)
        return self

    def role_of(self, index: int) -> str | None:
        """The role of UAV ``index`` (0-based), or None."""
        first = 0
        for name, role in self.roles.items():
            if first <= index < first + role.count:
                return name
            first += role.count
        return None

    def payload_of(self, index: int) -> tuple[str, ...]:
        """What UAV ``index`` carries (its role's payload)."""
        role = self.role_of(index)
        return tuple(self.roles[role].payload) if role is not None else ()


def uav_problems(names: Iterable[str], swarm: SwarmPlan | None) -> list[str]:
    """Why the ``uav:`` names of a mission's steps and triggers are wrong (none for a mission without them)."""
    problems: list[str] = []
    for name in dict.fromkeys(names):
        if swarm is None:
            problems.append(f"uav: {name!r} needs a swarm: block (a mission flown by one drone names no UAV)")
        elif name != ANY and name not in swarm.roles:
            roles = ", ".join(swarm.roles) or "none"
            problems.append(f"uav: {name!r} is neither 'any' nor a role of swarm.roles ({roles})")
    return problems


__all__ = ["ANY", "Corner", "Heartbeat", "Role", "RoleName", "Separation", "SwarmPlan", "Verification", "uav_problems"]
