"""Running a mission end to end: the simulated vehicle, perception, the tools, the reasoner, the trace and the
report (``agentic-uav run``)."""
