"""Built-in tools every drone agent gets: weather, alerts (e-mail, webhook, notify) and a shared incident log.

Their settings live in one :class:`BuiltinConfig` (read from ``AGENTIC_UAV_*`` variables by default). With nothing
configured they still work offline: simulated weather, alerts kept in the outbox, incidents in a local SQLite file.

>>> import tempfile
>>> from pathlib import Path
>>> from tools import Caller, ToolExecutor, ToolRegistry
>>> folder = Path(tempfile.mkdtemp())
>>> registry = ToolRegistry()
>>> register_builtins(registry, BuiltinConfig(outbox_dir=folder / "outbox", incidents_db=folder / "incidents.db"))
['weather.get_forecast', 'alerts.send_email', 'alerts.webhook', 'alerts.notify', 'incidents.log', 'incidents.query']
>>> executor = ToolExecutor(registry, default_caller=Caller(id="drone-1", scopes=frozenset({"weather:read"})))
>>> result = executor.call("weather.get_forecast", {"lat": 21.4133, "lon": 39.8933, "hours": 2})
>>> result.output["current"]["wind_speed_mps"], len(result.output["hourly"])
(4.0, 2)
>>> executor.call("alerts.notify", {"subject": "Test", "body": "Hello"}).status
'denied'
"""

from __future__ import annotations

from ..registry import ToolRegistry
from .alerts import NotifyReceipt, alert_tools, notify
from .config import MINA_AT_NOON, BuiltinConfig, SimulatedWeather
from .incidents import Incident, IncidentLogged, Incidents, IncidentStore, Near, incident_tools
from .mail import EmailReceipt, send_email
from .weather import Conditions, Forecast, get_forecast, weather_tools
from .webhook import WebhookReceipt, post_webhook


def register_builtins(registry: ToolRegistry, config: BuiltinConfig | None = None) -> list[str]:
    """Register every built-in tool, bound to ``config`` (from the environment when None); returns their names."""
    settings = config if config is not None else BuiltinConfig.from_env()
    specs = [*weather_tools(settings), *alert_tools(settings), *incident_tools(settings)]
    return [registry.register(spec).name for spec in specs]


__all__ = [
    "MINA_AT_NOON",
    "BuiltinConfig",
    "Conditions",
    "EmailReceipt",
    "Forecast",
    "Incident",
    "IncidentLogged",
    "IncidentStore",
    "Incidents",
    "Near",
    "NotifyReceipt",
    "SimulatedWeather",
    "WebhookReceipt",
    "get_forecast",
    "notify",
    "post_webhook",
    "register_builtins",
    "send_email",
]
