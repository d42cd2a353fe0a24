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

import functools
import math
from collections.abc import Callable
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


class NormalStream:
    """Standard normal draws from a generator, fetched in blocks.

    Why: the simulator draws three gust values per control tick, and one call into numpy costs more than the whole
    gust update. numpy's generators produce one stream of values whatever the size of each request (drawing 3 and 3
    gives the values of drawing 6), so as long as every draw from ``rng`` goes through this object, the values are
    exactly those of drawing them one request at a time.
    """

    def __init__(self, rng: np.random.Generator, block: int = 384) -> None:
        self._rng = rng
        self._block = block
        self._buffer: list[float] = []
        self._next = 0

    def take(self, n: int) -> list[float]:
        """The next ``n`` values of the stream."""
        if self._next + n > len(self._buffer):
            rest = self._buffer[self._next :]
            self._buffer = rest + self._rng.standard_normal(max(self._block, n)).tolist()
            self._next = 0
        start = self._next
        self._next = start + n
        return self._buffer[start : self._next]


Normals = np.random.Generator | NormalStream
"""Where a process draws its noise: a generator (one numpy call per draw) or a :class:`NormalStream` over one."""


def _take(normals: Normals, n: int) -> list[float]:
    if isinstance(normals, NormalStream):
        return normals.take(n)
    return [float(z) for z in normals.standard_normal(n)]


class GaussMarkov3:
    """Three independent first-order Gauss–Markov processes, exact discretisation (stationary from the start)."""

    def __init__(self, std: tuple[float, float, float], tau_s: float, rng: Normals) -> None:
        if tau_s <= 0:
            raise ValueError("tau_s must be positive")
        self.std = std
        self.tau_s = tau_s
        self._rng = rng
        self._draw3: Callable[[], list[float]] = (
            functools.partial(rng.take, 3) if isinstance(rng, NormalStream) else functools.partial(_take, rng, 3)
        )
        if isinstance(rng, NormalStream):
            z = rng.take(3)
            self.value = [s * z[i] for i, s in enumerate(std)]
        else:
            self.value = [s * float(rng.standard_normal()) for s in std]
        self._dt = math.nan
        self._a = self._b = 0.0

    def step(self, dt: float) -> list[float]:
        if dt != self._dt:  # the coefficients depend on dt only, and the simulator steps at one rate
            a = math.exp(-dt / self.tau_s)
            self._dt, self._a, self._b = dt, a, math.sqrt(1.0 - a * a)
        a, b = self._a, self._b
        z0, z1, z2 = self._draw3()
        v0, v1, v2 = self.value
        s0, s1, s2 = self.std
        self.value = [a * v0 + b * s0 * z0, a * v1 + b * s1 * z1, a * v2 + b * s2 * z2]
        return self.value


class Gusts:
    """The gust velocity (m/s, NED) for a :class:`WindSettings`, advanced by the simulator."""

    def __init__(self, settings: WindSettings, rng: Normals) -> None:
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

    def __init__(self, settings: GpsNoiseSettings, rng: Normals) -> None:
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
        w = _take(self._rng, 6)
        hw, vw, sv = s.horizontal_white_std_m, s.vertical_white_std_m, s.velocity_std_mps
        self.position_error = (bn + hw * w[0], be + hw * w[1], bd + vw * w[2])
        self.velocity_error = (sv * w[3], sv * w[4], sv * w[5])
        return self.position_error


@dataclass(frozen=True, slots=True)
class Environment:
    """Everything outside the airframe: home, wind, GPS error model."""

    home: Home = field(default_factory=Home)
    wind: WindSettings = field(default_factory=WindSettings)
    gps: GpsNoiseSettings = field(default_factory=GpsNoiseSettings)
