"""Control refined from traces: the position controller's gains tuned by CMA-ES against tracking error, energy and
jerk computed from recorded telemetry, accepted only when held-out wind-gust flights improve significantly."""
