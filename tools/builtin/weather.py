"""``weather.get_forecast``: wind, gusts, visibility and temperature at a place, now and hour by hour.

With ``weather_base_url`` set it asks an Open-Meteo-compatible API: ``GET {base}/v1/forecast`` with ``latitude``,
``longitude``, ``current`` and ``hourly`` (comma-separated variable names ``temperature_2m``, ``wind_speed_10m``,
``wind_direction_10m``, ``wind_gusts_10m``, ``visibility``), ``wind_speed_unit=ms`` and ``forecast_hours``. The
answer holds ``latitude``/``longitude`` (the grid point used), ``current`` (``time``, ``interval`` and one number per
variable), ``current_units``, ``hourly`` (a ``time`` list and one list per variable) and ``hourly_units``; times are
ISO 8601 without seconds, in GMT unless ``timezone`` is given; visibility is in metres. A refused request is HTTP 400
with ``{"error": true, "reason": "..."}``. Without a base URL, the flight simulator's ``weather_provider`` or the
embedded static environment answers (source ``simulated``).

>>> forecast = get_forecast(BuiltinConfig(), 21.4133, 39.8933, hours=3)
>>> forecast.source, forecast.current.wind_speed_mps, forecast.current.wind_direction_deg, len(forecast.hourly)
('simulated', 4.0, 315.0, 3)
"""

from __future__ import annotations

from datetime import UTC, datetime, timedelta
from typing import Annotated, Any, Literal

import httpx
from pydantic import BaseModel, Field

from ..egress import fenced, guarded_client
from ..errors import ToolError, TransientToolError
from ..function import spec_from_function
from ..spec import ToolSpec
from .config import MINA_AT_NOON, BuiltinConfig, SimulatedWeather, egress_policy

VARIABLES = ("temperature_2m", "wind_speed_10m", "wind_direction_10m", "wind_gusts_10m", "visibility")
MAX_HOURS = 384  # Open-Meteo forecasts 16 days at most
_TO_MPS = {"m/s": 1.0, "ms": 1.0, "km/h": 1 / 3.6, "kmh": 1 / 3.6, "mph": 0.44704, "kn": 0.514444, "knots": 0.514444}

Latitude = Annotated[float, Field(ge=-90, le=90, description="latitude in degrees (WGS84)")]
Longitude = Annotated[float, Field(ge=-180, le=180, description="longitude in degrees (WGS84)")]


class Conditions(BaseModel):
    """The weather at one time; a value the source did not report is null."""

    time: str = Field(description="ISO 8601 (UTC for the simulated source, GMT for Open-Meteo)")
    wind_speed_mps: float | None = Field(description="mean wind 10 m above ground, m/s")
    wind_direction_deg: float | None = Field(description="where the wind comes from, degrees clockwise from north")
    wind_gusts_mps: float | None = Field(description="gusts 10 m above ground, m/s")
    visibility_m: float | None
    temperature_c: float | None = Field(description="air temperature 2 m above ground")


class Forecast(BaseModel):
    """Current conditions and an hourly forecast at a point."""

    source: Literal["open-meteo", "simulated"]
    lat: float = Field(description="the point the forecast is for (Open-Meteo snaps to its grid)")
    lon: float
    current: Conditions
    hourly: list[Conditions]


def get_forecast(config: BuiltinConfig, lat: float, lon: float, hours: int = 24) -> Forecast:
    """The forecast at ``(lat, lon)`` for the next ``hours`` hours, from the source ``config`` chooses."""
    if config.weather_base_url:
        return _open_meteo(config, config.weather_base_url, lat, lon, hours)
    return simulated_forecast(config, lat, lon, hours)


# --- the simulated source ----------------------------------------------------------------------------------------
def simulated_forecast(
    config: BuiltinConfig, lat: float, lon: float, hours: int, now: datetime | None = None
) -> Forecast:
    """The provider's (or the static default's) conditions now, held for every hour ahead (persistence)."""
    weather = config.weather_provider(lat, lon) if config.weather_provider is not None else MINA_AT_NOON
    moment = (now or datetime.now(UTC)).astimezone(UTC)
    start = moment.replace(minute=0, second=0, microsecond=0)

    def at(time: datetime) -> Conditions:
        return _conditions(time.strftime("%Y-%m-%dT%H:%M"), weather)

    return Forecast(
        source="simulated",
        lat=lat,
        lon=lon,
        current=at(moment),
        hourly=[at(start + timedelta(hours=h)) for h in range(hours)],
    )


def _conditions(time: str, weather: SimulatedWeather) -> Conditions:
    return Conditions(
        time=time,
        wind_speed_mps=weather.wind_speed_mps,
        wind_direction_deg=weather.wind_direction_deg,
        wind_gusts_mps=weather.wind_gusts_mps,
        visibility_m=weather.visibility_m,
        temperature_c=weather.temperature_c,
    )


# --- Open-Meteo --------------------------------------------------------------------------------------------------
def _open_meteo(config: BuiltinConfig, base_url: str, lat: float, lon: float, hours: int) -> Forecast:
    params: dict[str, str | int | float] = {
        "latitude": lat,
        "longitude": lon,
        "current": ",".join(VARIABLES),
        "hourly": ",".join(VARIABLES),
        "wind_speed_unit": "ms",
        "forecast_hours": hours,
    }
    url = base_url.rstrip("/") + "/v1/forecast"
    try:
        with guarded_client(egress_policy(config), config.http_timeout_s) as client:
            response = client.get(url, params=params)
    except httpx.TransportError as exc:
        raise TransientToolError(f"the weather service did not answer: {type(exc).__name__}: {exc}") from exc
    status = response.status_code
    if status in (408, 425, 429) or status >= 500:
        raise TransientToolError(f"the weather service is unavailable (HTTP {status} {response.reason_phrase})")
    body = _json(response)
    if status >= 400:
        reason = body.get("reason") if isinstance(body, dict) else None
        text = fenced(str(reason) if reason else response.text, 300)
        raise ToolError(f"the weather service refused the request (HTTP {status}): {text}")
    if not isinstance(body, dict) or not isinstance(body.get("current"), dict):
        raise ToolError(f"the weather service answered HTTP {status} without the 'current' conditions")
    return _parse(body, lat, lon, hours)


def _json(response: httpx.Response) -> Any:
    try:
        return response.json()
    except ValueError:
        return None


def _parse(body: dict[str, Any], lat: float, lon: float, hours: int) -> Forecast:
    current_units = body.get("current_units") or {}
    hourly_units = body.get("hourly_units") or {}
    current = _open_meteo_conditions(body["current"], current_units)
    table = body.get("hourly") or {}
    times = table.get("time") or []
    hourly = [
        _open_meteo_conditions(
            {k: v[i] if isinstance(v, list) and i < len(v) else None for k, v in table.items()}, hourly_units
        )
        for i in range(min(len(times), hours))
    ]
    return Forecast(
        source="open-meteo",
        lat=_number(body.get("latitude")) if body.get("latitude") is not None else lat,
        lon=_number(body.get("longitude")) if body.get("longitude") is not None else lon,
        current=current,
        hourly=hourly,
    )


def _open_meteo_conditions(values: dict[str, Any], units: dict[str, Any]) -> Conditions:
    time = values.get("time")
    try:
        datetime.fromisoformat(str(time))
    except ValueError:
        raise ToolError(f"the weather service gave a time that is not ISO 8601: {str(time)[:40]!r}") from None
    factor = _TO_MPS.get(str(units.get("wind_speed_10m", "m/s")).lower())
    gust_factor = _TO_MPS.get(str(units.get("wind_gusts_10m", units.get("wind_speed_10m", "m/s"))).lower())
    if factor is None or gust_factor is None:
        raise ToolError(f"the weather service gave wind in an unknown unit: {units.get('wind_speed_10m')!r}")

    def scaled(name: str, scale: float = 1.0) -> float | None:
        value = _number(values.get(name))
        return None if value is None else round(value * scale, 3)

    return Conditions(
        time=str(time),
        wind_speed_mps=scaled("wind_speed_10m", factor),
        wind_direction_deg=scaled("wind_direction_10m"),
        wind_gusts_mps=scaled("wind_gusts_10m", gust_factor),
        visibility_m=scaled("visibility"),
        temperature_c=scaled("temperature_2m"),
    )


def _number(value: Any) -> float | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ToolError(f"the weather service gave a value that is not a number: {str(value)[:40]!r}")
    return float(value)


# --- the tool ------------------------------------------------------------------------------------------------------
def weather_tools(config: BuiltinConfig) -> list[ToolSpec]:
    """``weather.get_forecast`` bound to ``config``."""

    def forecast(lat: Latitude, lon: Longitude, hours: Annotated[int, Field(ge=1, le=MAX_HOURS)] = 24) -> Forecast:
        """Current wind, gusts, visibility and temperature at a place, and an hourly forecast.

        Args:
            lat: latitude in degrees (WGS84)
            lon: longitude in degrees (WGS84)
            hours: how many hours ahead to forecast (1 to 384)
        """
        return get_forecast(config, lat, lon, hours)

    return [
        spec_from_function(
            forecast,
            name="weather.get_forecast",
            scopes=["weather:read"],
            idempotent=True,
            cache_ttl_s=300,
            retry=3,
            rate_limit="10/s",
            timeout_s=config.http_timeout_s * 2 + 5,
        )
    ]


__all__ = ["Conditions", "Forecast", "get_forecast", "simulated_forecast", "weather_tools"]
