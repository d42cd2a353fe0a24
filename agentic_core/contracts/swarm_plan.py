"""A swarm mission's own block (``swarm:`` in a mission file): how many UAVs, the area they split into sectors,
their roles, the altitude layers and separation they keep, and how many must see a casualty before the alert.
Steps and triggers name who does them with ``uav:`` (a role, or ``any``); :func:`uav_problems` checks those names.

>>> plan = SwarmPlan.model_validate({"area": [{"lat": 21.41, "lon": 39.89}, {"lat": 21.42, "lon": 39.89},
...                                            {"lat": 21.42, "lon": 39.90}], "roles": {"medic": {"count": 1,
...                                            "payload": ["medkit"]}}})
>>> plan.vehicles, plan.role_of(0), plan.role_of(1), plan.payload_of(0)
(4, 'medic', None, ('medkit',))
>>> uav_problems(["any", "medic", "pilot"], plan)
["uav: 'pilot' is neither 'any' nor a role of swarm.roles (medic)"]
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, StringConstraints, model_validator

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


class SwarmPlan(_Contract):
    """The ``swarm:`` block of a mission flown by several UAVs (``agentic-uav swarm run``)."""

    vehicles: int = Field(default=4, ge=1, le=64, description="UAVs when --vehicles is not given")
    area: list[Corner] = Field(min_length=3, description="the area the UAVs split into sectors, one per UAV")
    roles: dict[RoleName, Role] = Field(default_factory=dict, description="roles, given to the first UAVs in order")
    layers_m: list[Annotated[float, Field(gt=0)]] = Field(
        default_factory=lambda: [30.0, 40.0, 50.0, 60.0],
        min_length=1,
        description="altitude layers above home; UAV i cruises in layer i modulo their number",
    )
    separation: Separation = Field(default_factory=Separation)
    verify_k: int = Field(
        default=2, ge=1, le=64, description="UAVs that must see a casualty (k of n) before swarm.verify says so"
    )
    pad_spacing_m: float = Field(default=20.0, gt=0, description="launch pads along east, this far apart")

    @model_validator(mode="after")
    def _names(self) -> SwarmPlan:
        if ANY in self.roles:
            raise ValueError(f"{ANY!r} cannot be a role's name: it means every UAV")
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


__all__ = ["ANY", "Corner", "Role", "RoleName", "Separation", "SwarmPlan", "uav_problems"]
