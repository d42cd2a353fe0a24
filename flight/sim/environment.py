"""Where and in what weather the simulated F450 flies: home position, wind and gusts, GPS noise.

* **Home** defaults to the Mina valley east of Makkah (21.4133 N, 39.8933 E). Makkah's centre lies at about 277 m
  above sea level and Mina, 5–6 km east up the valley, a little higher; 300 m is used as the (flat) terrain
  elevation. There is no terrain model: the ground is a plane at the home elevation.
* **Wind** is a steady NED vector plus gusts. Gusts are a first-order Gauss–Markov (Ornstein–Uhlenbeck) process per
  axis with standard deviation ``gust_std_mps`` and correlation time ``gust_tau_s``, drawn from a seeded generator
  and written to JSBSim's gust properties by the simulator. Wind vectors are the velocity the air moves *towards*;
  :meth:`WindSettings.from_direction` takes the meteorological "blowing from" direction instead.
* **GPS noise**: the reported position is the truth plus a slowly wandering error (Gauss–Markov, ``bias_std`` and
  ``bias_tau_s``) and white noise (``white_std``), horizontal and vertical separately, updated at ``rate_hz``.
  The stationary standard deviation per axis is ``sqrt(bias_std² + white_std²)``. The defaults (about 0.7 m
  horizontal per axis, 1.2 m vertical) are in line with a consumer GNSS receiver without RTK.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

DEFAULT_HOME_LAT_DEG = 21.4133
DEFAULT_HOME_LON_DEG = 39.8933
DEFAULT_HOME_ALT_MSL_M = 300.0


@dataclass(frozen=True, slots=True)
class Home:
    """The take-off point: geodetic latitude/longitude (degrees) and ground elevation above mean sea level (m)."""

    lat_deg: float = DEFAULT_HOME_LAT_DEG
    lon_deg: float = DEFAULT_HOME_LON_DEG
    alt_msl_m: float = DEFAULT_HOME_ALT_MSL_M
    heading_deg: float = 0.0

    def __post_init__(self) -> None:
        if not (-90.0 < self.lat_deg < 90.0 and -180.0 <= self.lon_deg <= 180.0):
            raise ValueError(f"home position out of range: {self.lat_deg}, {self.lon_deg}")
        if not -500.0 <= self.alt_msl_m <= 9000.0:
            raise ValueError(f"home elevation out of range: {self.alt_msl_m} m")


@dataclass(frozen=True, slots=True)
class WindSettings:
    """Steady wind (m/s, NED, the direction the air moves towards) plus Gauss–Markov gusts."""

    north_mps: float = 0.0
    east_mps: float = 0.0
    down_mps: float = 0.0
    gust_std_mps: float = 0.0
    """Horizontal gust standard deviation per axis; vertical gusts get half of it."""
    gust_tau_s: float = 2.0

    @classmethod
    def from_direction(
        cls, speed_mps: float, from_deg: float, gust_std_mps: float = 0.0, gust_tau_s: float = 2.0
    ) -> WindSettings:
        """Wind of ``speed_mps`` blowing *from* ``from_deg`` (true, clockwise from north), as meteorologists say."""
        to = math.radians(from_deg + 180.0)
        return cls(speed_mps * math.cos(to), speed_mps * math.sin(to), 0.0, gust_std_mps, gust_tau_s)


class GaussMarkov3:
    """Three independent first-order Gauss–Markov processes, exact discretisation (stationary from the start)."""

    def __init__(self, std: tuple[float, float, float], tau_s: float, rng: np.random.Generator) -> None:
        if tau_s <= 0:
            raise ValueError("tau_s must be positive")
        self.std = std
        self.tau_s = tau_s
        self._rng = rng
        self.value = [s * float(rng.standard_normal()) for s in std]

    def step(self, dt: float) -> list[float]:
        a = math.exp(-dt / self.tau_s)
        b = math.sqrt(1.0 - a * a)
        z = self._rng.standard_normal(3)
        self.value = [a * v + b * s * float(n) for v, s, n in zip(self.value, self.std, z, strict=True)]
        return self.value


class Gusts:
    """The gust velocity (m/s, NED) for a :class:`WindSettings`, advanced by the simulator."""

    def __init__(self, settings: WindSettings, rng: np.random.Generator) -> None:
        s = settings.gust_std_mps
        self._process = GaussMarkov3((s, s, 0.5 * s), settings.gust_tau_s, rng) if s > 0 else None

    def step(self, dt: float) -> tuple[float, float, float]:
        if self._process is None:
            return 0.0, 0.0, 0.0
        n, e, d = self._process.step(dt)
        return n, e, d


@dataclass(frozen=True, slots=True)
class GpsNoiseSettings:
    """GPS position error model (m). Zeros everywhere give a perfect receiver."""

    horizontal_bias_std_m: float = 0.6
    horizontal_white_std_m: float = 0.3
    vertical_bias_std_m: float = 1.0
    vertical_white_std_m: float = 0.6
    bias_tau_s: float = 60.0
    velocity_std_mps: float = 0.05
    rate_hz: float = 10.0
    satellites: int = 12

    @property
    def horizontal_std_m(self) -> float:
        """Stationary standard deviation of the error per horizontal axis."""
        return math.hypot(self.horizontal_bias_std_m, self.horizontal_white_std_m)

    @property
    def vertical_std_m(self) -> float:
        return math.hypot(self.vertical_bias_std_m, self.vertical_white_std_m)


class GpsNoise:
    """Samples GPS position and velocity errors (NED, m and m/s) at the configured rate."""

    def __init__(self, settings: GpsNoiseSettings, rng: np.random.Generator) -> None:
        self.settings = settings
        self._rng = rng
        hb, vb = settings.horizontal_bias_std_m, settings.vertical_bias_std_m
        self._bias = GaussMarkov3((hb, hb, vb), settings.bias_tau_s, rng)
        self.position_error: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self.velocity_error: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self.step()

    @property
    def period_s(self) -> float:
        return 1.0 / self.settings.rate_hz

    def step(self) -> tuple[float, float, float]:
        """Advance one GPS epoch; returns the new position error (north, east, down)."""
        s = self.settings
        bn, be, bd = self._bias.step(self.period_s)
        w = self._rng.standard_normal(6)
        hw, vw, sv = s.horizontal_white_std_m, s.vertical_white_std_m, s.velocity_std_mps
        self.position_error = (bn + hw * float(w[0]), be + hw * float(w[1]), bd + vw * float(w[2]))
        self.velocity_error = (sv * float(w[3]), sv * float(w[4]), sv * float(w[5]))
        return self.position_error


@dataclass(frozen=True, slots=True)
class Environment:
    """Everything outside the airframe: home, wind, GPS error model."""

    home: Home = field(default_factory=Home)
    wind: WindSettings = field(default_factory=WindSettings)
    gps: GpsNoiseSettings = field(default_factory=GpsNoiseSettings)
