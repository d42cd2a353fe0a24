"""An example of your own tool flown in a mission: a perimeter fence's sensor reading (simulated here).

agentic-uav run tools/examples/fence_check.yaml --tools tools/examples/fence_tools.py
"""

from tools import tool


@tool(name="fence.status", scopes=["fence:read"], idempotent=True)
def fence_status(segment: str) -> dict[str, object]:
    """The state of one fence segment, as its sensor reports it.

    Args:
        segment: the segment's id, e.g. "F-07"
    """
    breached = segment == "F-07"  # a real tool would ask the site's sensor network
    return {"segment": segment, "breached": breached, "lat": 21.4141, "lon": 39.8952}
