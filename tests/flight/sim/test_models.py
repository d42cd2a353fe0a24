"""Battery, GPS noise and geodesy, without flying."""

import itertools
import math

import numpy as np
import pytest

from flight.sim import (
    Battery,
    BatteryConfig,
    GpsNoise,
    GpsNoiseSettings,
    Simulator,
    WindSettings,
    cell_ocv,
    geodetic_to_ned,
    ned_to_geodetic,
)
from flight.sim.environment import Home


def test_cell_voltage_curve_is_monotonic_and_spans_a_lipo():
    socs = np.linspace(0.0, 1.0, 101)
    volts = [cell_ocv(float(s)) for s in socs]
    assert volts[0] == pytest.approx(3.27)
    assert volts[-1] == pytest.approx(4.20)
    assert all(b >= a for a, b in itertools.pairwise(volts))
    assert 3.7 < cell_ocv(0.5) < 3.9


def test_pack_voltage_scales_with_cells():
    assert Battery(BatteryConfig(cells=3)).open_circuit_voltage() == pytest.approx(12.6)
    assert Battery(BatteryConfig(cells=4)).open_circuit_voltage() == pytest.approx(16.8)
    with pytest.raises(ValueError):
        BatteryConfig(cells=5)


def test_battery_drains_faster_at_higher_throttle():
    low, high = Battery(), Battery()
    for _ in range(60 * 50):
        low.update([0.3] * 4, 0.02)
        high.update([0.6] * 4, 0.02)
    assert high.used_mah > 2.0 * low.used_mah > 0.0
    assert high.voltage_v < low.voltage_v
    # Hover (0.41 on 4S) draws about 10-15 A: 5000 mAh lasts roughly 20 minutes.
    hover = Battery()
    assert 8.0 < hover.estimate_current([0.41] * 4) < 16.0


def test_battery_drains_monotonically_through_a_flight():
    sim = Simulator()
    sim.arm()
    sim.takeoff(10.0)
    pct, volts, amps = [], [], []
    for _ in range(30):
        sim.run_for(1.0)
        s = sim.state()
        pct.append(s.battery_pct)
        volts.append(s.battery_voltage_v)
        amps.append(s.battery_current_a)
    assert all(b < a for a, b in itertools.pairwise(pct))
    assert pct[-1] < 100.0
    assert 8.0 < amps[-1] < 16.0  # hovering
    assert volts[-1] < 16.8


def test_empty_battery_stays_empty_and_refuses_to_arm():
    sim = Simulator(battery=BatteryConfig(initial_soc=0.0))
    assert sim.state().battery_pct == 0.0
    assert not sim.arm()


def test_gps_noise_statistics_match_the_settings():
    settings = GpsNoiseSettings(
        horizontal_bias_std_m=0.6,
        horizontal_white_std_m=0.3,
        vertical_bias_std_m=1.0,
        vertical_white_std_m=0.6,
        bias_tau_s=1.0,
    )
    gps = GpsNoise(settings, np.random.default_rng(123))
    errs = np.array([gps.step() for _ in range(40_000)])
    std = errs.std(axis=0)
    assert std[0] == pytest.approx(settings.horizontal_std_m, rel=0.05)
    assert std[1] == pytest.approx(settings.horizontal_std_m, rel=0.05)
    assert std[2] == pytest.approx(settings.vertical_std_m, rel=0.05)
    assert np.all(np.abs(errs.mean(axis=0)) < 0.05)
    # Consecutive epochs (0.1 s apart) share the slowly varying bias: strongly but not fully correlated.
    expected = math.exp(-0.1) * 0.6**2 / (0.6**2 + 0.3**2)
    lag1 = np.corrcoef(errs[:-1, 0], errs[1:, 0])[0, 1]
    assert lag1 == pytest.approx(expected, abs=0.03)


def test_gps_fix_wanders_around_the_truth():
    sim = Simulator(seed=11)
    offsets = []
    for _ in range(100):
        sim.run_for(0.1)
        fix = sim.gps_fix()
        home = sim.environment.home
        n, e, _ = geodetic_to_ned(fix.lat_deg, fix.lon_deg, fix.alt_msl_m, home.lat_deg, home.lon_deg, home.alt_msl_m)
        offsets.append(math.hypot(n, e))
    assert 0.0 < float(np.mean(offsets)) < 3.0
    assert len(set(offsets)) > 50  # a new error every GPS epoch
    assert fix.fix_type == 3 and fix.satellites > 5


def test_zero_noise_gps_reports_the_truth():
    from flight.sim import Environment

    quiet = GpsNoiseSettings(0.0, 0.0, 0.0, 0.0)
    sim = Simulator(environment=Environment(gps=quiet))
    sim.run_for(0.5)
    fix, s = sim.gps_fix(), sim.state()
    assert fix.lat_deg == pytest.approx(s.lat_deg, abs=1e-9)
    assert fix.alt_msl_m == pytest.approx(s.alt_msl_m, abs=1e-6)


def test_geodesy_round_trip_and_scale():
    lat, lon, alt = ned_to_geodetic(1000.0, -500.0, -20.0, 21.4133, 39.8933, 300.0)
    n, e, d = geodetic_to_ned(lat, lon, alt, 21.4133, 39.8933, 300.0)
    assert (n, e, d) == pytest.approx((1000.0, -500.0, -20.0), abs=1e-6)
    # One degree of latitude near 21 N is about 110.7 km.
    n1, _, _ = geodetic_to_ned(22.4133, 39.8933, 300.0, 21.4133, 39.8933, 300.0)
    assert n1 == pytest.approx(110_700.0, rel=0.002)


def test_wind_from_direction_is_meteorological():
    w = WindSettings.from_direction(10.0, from_deg=270.0)  # a westerly blows towards the east
    assert w.east_mps == pytest.approx(10.0)
    assert w.north_mps == pytest.approx(0.0, abs=1e-9)


def test_home_is_validated():
    with pytest.raises(ValueError):
        Home(lat_deg=95.0)
    with pytest.raises(ValueError):
        Home(alt_msl_m=20_000.0)
