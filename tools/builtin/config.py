"""Settings of the built-in tools in one pydantic model, read from ``AGENTIC_UAV_*`` environment variables.

>>> env = {"AGENTIC_UAV_SMTP_PORT": "2525", "AGENTIC_UAV_ALERT_RECIPIENTS": "a@x.org, b@x.org"}
>>> config = BuiltinConfig.from_env(env)
>>> config.smtp_port, config.alert_recipients, config.smtp_host is None
(2525, ['a@x.org', 'b@x.org'], True)
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, SecretStr, ValidationError

from ..egress import EgressPolicy, parse_allow

ENV_PREFIX = "AGENTIC_UAV_"
LIST_SETTINGS = frozenset({"alert_recipients", "alert_allow", "attachment_dirs", "egress_allow", "webhook_allow"})
"""The settings written as comma-separated lists."""


class SimulatedWeather(BaseModel):
    """The weather at one place, as the flight simulator (or the embedded default) supplies it."""

    model_config = ConfigDict(frozen=True)

    wind_speed_mps: float = Field(ge=0)
    wind_direction_deg: float = Field(ge=0, le=360, description="where the wind comes from, clockwise from north")
    wind_gusts_mps: float = Field(ge=0)
    visibility_m: float = Field(ge=0)
    temperature_c: float


MINA_AT_NOON = SimulatedWeather(
    wind_speed_mps=4.0, wind_direction_deg=315.0, wind_gusts_mps=6.0, visibility_m=10_000.0, temperature_c=35.0
)
"""The embedded default: a gentle north-westerly of 4 m/s (gusts 6 m/s), 10 km visibility, 35 °C, as at Mina at noon."""


class BuiltinConfig(BaseModel):
    """Where the built-in tools send and keep things. :meth:`from_env` reads these variables (empty means unset):

    - ``AGENTIC_UAV_OUTBOX_DIR``: where undeliverable alerts are written (``.eml``, ``.json``, ``notifications.jsonl``);
      default ``runs/outbox``.
    - ``AGENTIC_UAV_INCIDENTS_DB``: the SQLite incident log; default ``runs/incidents.db``.
    - ``AGENTIC_UAV_ATTACHMENT_DIRS``: the only folders whose files alerts may attach (comma-separated; default
      ``runs``), so an agent talked into mailing ``~/.ssh`` out cannot.
    - ``AGENTIC_UAV_WEATHER_BASE_URL``: an Open-Meteo-compatible API, e.g. ``https://api.open-meteo.com``; unset, the
      weather comes from ``weather_provider`` or the embedded static environment (:data:`MINA_AT_NOON`).
    - ``AGENTIC_UAV_SMTP_HOST``, ``AGENTIC_UAV_SMTP_PORT`` (587), ``AGENTIC_UAV_SMTP_STARTTLS`` (true),
      ``AGENTIC_UAV_SMTP_USERNAME``, ``AGENTIC_UAV_SMTP_PASSWORD`` (kept as a secret, never logged),
      ``AGENTIC_UAV_SMTP_FROM``, ``AGENTIC_UAV_SMTP_CA_FILE`` (a PEM bundle to trust instead of the system's, for a
      private CA): mail delivery; with no host, mail goes to the outbox.
    - ``AGENTIC_UAV_ALERT_RECIPIENTS``: the addresses ``alerts.notify`` mails when given none (comma-separated);
      with ``AGENTIC_UAV_ALERT_ALLOW`` (more addresses, or ``@domain``), the only ones mail may go out to
      (:mod:`tools.builtin.allowlist`).
    - ``AGENTIC_UAV_WEBHOOK_URL``: where ``alerts.webhook`` posts when given no URL; unset, payloads go to the outbox.
      Its host and ``AGENTIC_UAV_WEBHOOK_ALLOW`` (host names) are the only hosts a webhook may reach.
    - ``AGENTIC_UAV_EGRESS_ALLOW``: internal hosts outbound HTTP (webhooks, weather, HTTP endpoint tools) may reach
      although the egress policy refuses internal addresses (comma-separated host names, addresses, networks such
      as ``10.20.0.0/16``); see :mod:`tools.egress`.
    - ``AGENTIC_UAV_HTTP_TIMEOUT_S``: the network timeout of the weather, webhook and SMTP clients (10 s).

    ``weather_provider(lat, lon)`` is set in code only (the flight simulator's live wind); it is never serialised.
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    outbox_dir: Path = Path("runs/outbox")
    incidents_db: Path = Path("runs/incidents.db")
    attachment_dirs: list[Path] = Field(default_factory=lambda: [Path("runs")])
    weather_base_url: str | None = None
    smtp_host: str | None = None
    smtp_port: int = Field(default=587, ge=1, le=65535)
    smtp_starttls: bool = True
    smtp_username: str | None = None
    smtp_password: SecretStr | None = None
    smtp_from: str = "agentic-uav@localhost"
    smtp_ca_file: Path | None = None
    alert_recipients: list[str] = Field(default_factory=list)
    alert_allow: list[str] = Field(default_factory=list)
    webhook_url: str | None = None
    webhook_allow: list[str] = Field(default_factory=list)
    http_timeout_s: float = Field(default=10.0, gt=0)
    egress_allow: list[str] = Field(default_factory=list)
    weather_provider: Callable[[float, float], SimulatedWeather] | None = Field(default=None, exclude=True, repr=False)

    @classmethod
    def from_env(cls, environ: Mapping[str, str] | None = None, **overrides: Any) -> BuiltinConfig:
        """The settings the environment gives (``os.environ`` unless ``environ``), then ``overrides``."""
        env = os.environ if environ is None else environ
        values: dict[str, Any] = {}
        for name in cls.model_fields:
            if name == "weather_provider":
                continue
            raw = env.get(ENV_PREFIX + name.upper(), "").strip()
            if raw:
                split = [a.strip() for a in raw.replace(";", ",").split(",") if a.strip()]
                values[name] = split if name in LIST_SETTINGS else raw
        values.update(overrides)
        try:
            return cls(**values)
        except ValidationError as exc:
            problems = "; ".join(
                f"{ENV_PREFIX}{str(e['loc'][0]).upper()}: {e['msg']}" if e["loc"] else e["msg"] for e in exc.errors()
            )
            raise ValueError(f"bad built-in tool settings: {problems}") from None


def egress_policy(config: BuiltinConfig) -> EgressPolicy:
    """The egress policy of the built-in tools' outbound HTTP."""
    return EgressPolicy(allow=parse_allow(config.egress_allow))


def may_attach(config: BuiltinConfig, path: str | Path) -> bool:
    """Whether ``path`` lies inside one of ``config.attachment_dirs`` (symbolic links resolved)."""
    target = Path(path).expanduser().resolve()
    return any(target.is_relative_to(Path(folder).expanduser().resolve()) for folder in config.attachment_dirs)


__all__ = ["ENV_PREFIX", "MINA_AT_NOON", "BuiltinConfig", "SimulatedWeather", "egress_policy", "may_attach"]
