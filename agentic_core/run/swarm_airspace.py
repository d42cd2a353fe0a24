"""A swarm run's airspace: the mission's layers and separation, with the planning margin and the speeds the
simulated F450s fly legs at, so a reserved leg is one the aircraft can follow.

>>> from agentic_core.contracts.swarm_plan import SwarmPlan
>>> area = [{"lat": 0, "lon": 0}, {"lat": 0.001, "lon": 0}, {"lat": 0, "lon": 0.001}]
>>> airspace = swarm_airspace(SwarmPlan(area=area))
>>> airspace.layers, airspace.horizontal_m, airspace.vertical_m, airspace.speed_mps
((30.0, 40.0, 50.0, 60.0), 18.0, 8.0, 5.0)
"""

from __future__ import annotations

from ..contracts.swarm_plan import SwarmPlan
from ..swarm.deconflict import Airspace

MARGIN_M = 3.0
"""Added to the horizontal separation when legs are planned: what the aircraft may lag its plan by (accelerating,
turning, overshooting), so the separation flown stays above the configured one."""

CRUISE_MPS = 5.0
"""The vehicles' cruise (PX4's ``MPC_XY_CRUISE``), commanded on every leg the gate flies."""
CLIMB_MPS = 2.5
"""Between the controller's climb limit (3 m/s) and what a climb averages with its start and stop."""
DESCENT_MPS = 1.2
"""The controller's landing descent above its slow final metres."""
HOLD_S = 86_400.0
"""A UAV's hold after a leg lasts until its next leg (which cuts it) or its release: for the run, in effect."""


def swarm_airspace(plan: SwarmPlan) -> Airspace:
    """The shared airspace for ``plan``'s swarm."""
    return Airspace(
        layers=tuple(plan.layers_m), horizontal_m=plan.separation.horizontal_m + MARGIN_M,
        vertical_m=plan.separation.vertical_m, speed_mps=CRUISE_MPS, climb_mps=CLIMB_MPS, descent_mps=DESCENT_MPS,
        hold_s=HOLD_S,
    )  # fmt: skip


__all__ = ["CLIMB_MPS", "CRUISE_MPS", "DESCENT_MPS", "HOLD_S", "MARGIN_M", "swarm_airspace"]
