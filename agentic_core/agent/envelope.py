"""The flight envelope the dispatcher checks every resolved command with; it lives with the mission
(:mod:`agentic_core.mission.envelope`) so that ``validate`` checks a file with the very same geometry.

>>> from agentic_core.contracts.policy_graph import Limits
>>> Envelope(Limits(max_altitude_m=25), home=lambda: None).check("flight.takeoff", {"altitude_m": 30})
['altitude_m 30 m is above the ceiling of 25 m (limits.max_altitude_m)']
"""

from ..mission.envelope import FLOOR_M, Envelope

__all__ = ["FLOOR_M", "Envelope"]
