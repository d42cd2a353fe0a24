"""The faults of a swarm run (``agentic-uav swarm run --fault ground_link@t=60s``): the ground link lost at a time
of the swarm's clock, after which the UAVs allocate what is left among themselves by consensus
(:meth:`~agentic_core.swarm.coordinator.SwarmCoordinator.lose_ground`). A vehicle's faults are one drone's
(``agentic-uav run --fault``); this is the swarm's own.

>>> ground_link_lost_at(["ground_link@t=60s"])
60.0
>>> ground_link_lost_at([]) is None
True
>>> ground_link_lost_at(["gps_loss@t=5s"])
Traceback (most recent call last):
...
agentic_core.contracts.errors.InputError: --fault 'gps_loss@t=5s': a swarm run's fault is ground_link@t=SECONDS \
(e.g. ground_link@t=60s: the swarm's clock)
"""

from __future__ import annotations

import re
from collections.abc import Sequence

from ..contracts.errors import InputError

_GROUND_LINK = re.compile(r"^ground_link@t=(?P<t>[0-9]+(?:\.[0-9]+)?)s?$")
FORM = "ground_link@t=SECONDS (e.g. ground_link@t=60s: the swarm's clock)"


def ground_link_lost_at(faults: Sequence[str]) -> float | None:
    """When (seconds of the swarm's clock) the ground link is lost, or None; :class:`InputError` naming a fault
    that is not one, or a second one."""
    at: float | None = None
    for text in faults:
        found = _GROUND_LINK.match(text.strip())
        if found is None:
            raise InputError(f"--fault {text!r}: a swarm run's fault is {FORM}")
        if at is not None:
            raise InputError(f"--fault {text!r}: the ground link is lost once (already at t={at:g}s)")
        at = float(found["t"])
    return at


__all__ = ["FORM", "ground_link_lost_at"]
