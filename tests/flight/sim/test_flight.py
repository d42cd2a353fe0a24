"""Flying the simulated F450: take-off and hold, go-to, land, wind, limits, determinism, speed."""

import math
import time

from flight.sim import GoToPosition, Simulator, WindSettings

from .conftest import dist_to

HOME_HOVER = (0.0, 0.0, -10.0)


def test_starts_landed_and_disarmed_at_home():
    sim = Simulator()
    s = sim.state()
    assert s.landed and not s.armed
    assert s.setpoint == "Disarmed"
    assert abs(s.lat_deg - 21.4133) < 1e-6 and abs(s.lon_deg - 39.8933) < 1e-6
    assert abs(s.alt_msl_m - 300.0) < 0.05
    assert s.alt_agl_m < 0.05
    assert abs(s.north_m) < 0.01 and abs(s.east_m) < 0.01 and abs(s.down_m) < 0.01
    assert s.battery_pct == 100.0


def test_setpoints_are_refused_while_disarmed():
    sim = Simulator()
    assert not sim.takeoff(10.0)
    sim.run_for(2.0)
    assert sim.state().alt_agl_m < 0.05


def test_armed_on_the_ground_idles_without_lifting_off():
    sim = Simulator()
    assert sim.arm()
    sim.run_for(3.0)
    s = sim.state()
    assert s.armed and s.landed
    assert s.throttle == 0.1
    assert s.alt_agl_m < 0.05


def test_takeoff_to_10m_then_hold_within_half_a_metre_for_20s(hovering_sim):
    sim = hovering_sim
    errors = []
    for _ in range(20 * 50):  # every control tick (50 Hz) for 20 s
        sim.step(5)
        errors.append(dist_to(sim.state(), HOME_HOVER))
    s = sim.state()
    print(f"hold in still air: max error {max(errors):.4f} m over 20 s")
    assert max(errors) < 0.5
    assert abs(s.alt_agl_m - 10.0) < 0.5
    assert not s.landed and s.armed
    assert s.setpoint == "GoToPosition"


def test_goto_50m_north_east_arrives_within_1m(hovering_sim):
    sim = hovering_sim
    d = 50.0 / math.sqrt(2.0)
    target = (d, d, -10.0)
    t0 = sim.time_s
    assert sim.goto(*target)
    assert sim.run_until(lambda s: dist_to(s, target) < 1.0, timeout_s=30.0)
    elapsed = sim.time_s - t0
    sim.run_for(5.0)
    final = dist_to(sim.state(), target)
    print(f"go-to 50 m NE: within 1 m after {elapsed:.1f} s; error 5 s later {final:.4f} m")
    assert final < 1.0
    assert 50.0 / 8.0 < elapsed < 30.0  # cannot beat the 8 m/s speed limit


def test_goto_global_matches_ned(hovering_sim):
    sim = hovering_sim
    from flight.sim import ned_to_geodetic

    home = sim.environment.home
    lat, lon, alt = ned_to_geodetic(-20.0, 10.0, -15.0, home.lat_deg, home.lon_deg, home.alt_msl_m)
    assert sim.goto_global(lat, lon, alt)
    assert isinstance(sim.controller.setpoint, GoToPosition)
    assert sim.run_until(lambda s: dist_to(s, (-20.0, 10.0, -15.0)) < 0.5, timeout_s=30.0)
    s = sim.state()
    assert abs(s.alt_msl_m - alt) < 0.5


def test_land_touches_down_and_cuts_the_motors(hovering_sim):
    sim = hovering_sim
    assert not sim.disarm()  # refused in the air
    assert sim.land()
    assert sim.run_until(lambda s: not s.armed, timeout_s=40.0)
    sim.run_for(2.0)
    s = sim.state()
    assert s.landed and not s.armed
    assert s.setpoint == "Disarmed"
    assert s.throttle == 0.0
    assert max(sim.truth().motor_outputs) < 0.01
    assert s.alt_agl_m < 0.05
    assert math.hypot(s.north_m, s.east_m) < 0.5  # straight down


def test_steady_10mps_wind_moves_a_hovering_vehicle_less_than_1m(hovering_sim):
    sim = hovering_sim
    sim.set_wind(WindSettings(north_mps=0.0, east_mps=10.0))
    worst = 0.0
    tilt_into_wind = 0.0
    for _ in range(200):
        sim.run_for(0.1)
        s = sim.state()
        worst = max(worst, dist_to(s, HOME_HOVER))
        tilt_into_wind = min(tilt_into_wind, s.roll_rad)  # air moving east: lean west (roll left)
    print(f"10 m/s east wind: worst deviation {worst:.3f} m, roll {math.degrees(tilt_into_wind):.1f} deg")
    assert worst < 1.0
    assert math.degrees(tilt_into_wind) < -2.0  # the wind is really there and the vehicle fights it


def test_gusts_perturb_the_hover_but_the_controller_holds(hovering_sim):
    sim = hovering_sim
    sim.set_wind(WindSettings(north_mps=4.0, gust_std_mps=2.0, gust_tau_s=1.0))
    worst = 0.0
    for _ in range(100):
        sim.run_for(0.1)
        worst = max(worst, dist_to(sim.state(), HOME_HOVER))
    assert 0.01 < worst < 2.0


def test_velocity_setpoint_is_capped_by_the_speed_limit(hovering_sim):
    sim = hovering_sim
    assert sim.set_velocity(20.0, 0.0, 0.0)
    sim.run_for(10.0)
    s = sim.state()
    assert 7.0 < s.groundspeed_mps < 8.5
    assert abs(s.down_m + 10.0) < 1.0  # tilt compensation keeps the altitude while leaning


def test_same_seed_same_flight_different_seed_different_gusts():
    def fly(seed):
        sim = Simulator(seed=seed)
        sim.set_wind(WindSettings(east_mps=3.0, gust_std_mps=1.5, gust_tau_s=1.0))
        sim.arm()
        sim.takeoff(5.0)
        sim.run_for(8.0)
        return sim.state(), sim.gps_fix()

    a, ga = fly(3)
    b, gb = fly(3)
    c, gc = fly(4)
    assert a == b and ga == gb
    assert a.north_m != c.north_m and ga.lat_deg != gc.lat_deg


def test_payload_release_is_a_one_shot_flag(hovering_sim):
    sim = hovering_sim
    assert not sim.state().payload_released
    assert sim.release_payload()
    assert not sim.release_payload()
    assert sim.state().payload_released


def test_runs_much_faster_than_real_time():
    sim = Simulator()
    sim.arm()
    sim.takeoff(10.0)
    t0 = time.perf_counter()
    sim.run_for(30.0)
    ratio = 30.0 / (time.perf_counter() - t0)
    print(f"simulator with controller: {ratio:.0f}x real time")
    assert ratio > 20.0
