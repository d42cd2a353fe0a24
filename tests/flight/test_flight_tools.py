"""The flight.* tools: through the tools executor against the simulated vehicle, scopes, and their input schemas
accepting the arguments the mission DSL sends."""

import asyncio
import math
import socket

import jsonschema
import pytest
from pydantic import BaseModel

from agentic_core.contracts.geodesy import local_offset, offset_position
from agentic_core.mission import model as mission
from agentic_core.mission.steps import Environment, perform, prepare
from flight.tools import NEEDS_WORLD_MODEL, TIMEOUTS_S, beside, flight_tools, register_flight_tools
from flight.vehicle import FlightResult, Telemetry, VehicleClient
from tests.waiting import CONNECT_S
from tools import Caller, ToolExecutor, ToolRegistry

PILOT = Caller(id="pilot", scopes=frozenset({"flight:command", "flight:payload", "flight:read"}))
FLIGHT_ACTIONS = {action: tool for action, tool in mission.ACTION_TOOLS.items() if tool.startswith("flight.")}
ARGS_MODELS: dict[str, type[BaseModel]] = {
    "takeoff": mission.TakeoffArgs,
    "fly_to": mission.FlyToArgs,
    "orbit": mission.OrbitArgs,
    "hover": mission.HoverArgs,
    "land": mission.LandArgs,
    "rtl": mission.NoArgs,
    "deploy_payload": mission.DeployPayloadArgs,
}


def free_udp_port():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


FAST_FORWARD = 50.0
"""Fifty times real time: minutes of flight in seconds, yet the vehicle thread sleeps between ticks, so on a
loaded 2-core machine the client's threads are not starved (``speed=None`` would spin a core flat out)."""


@pytest.fixture
def vehicle_seed() -> int:
    return 9


@pytest.fixture
def executor(vehicle):
    registry = ToolRegistry()
    register_flight_tools(registry, lambda: VehicleClient.connect(vehicle.address, timeout_s=CONNECT_S))
    ex = ToolExecutor(registry, default_caller=PILOT)
    try:
        yield ex
    finally:
        ex.close()


def test_a_flight_through_the_executor(executor, vehicle):
    up = executor.call("flight.takeoff", {"altitude_m": 8})
    assert up.status == "ok", up.error
    assert up.output["status"] == "ok" and up.output["reached"] is True
    assert abs(up.output["state"]["alt_m"] - 8.0) < 0.6 and up.output["state"]["armed"]

    there = executor.call("flight.fly_to", {"north_m": 30.0, "east_m": -10.0, "alt_m": 12.0, "speed_mps": 6.0})
    assert there.status == "ok", there.error
    state = there.output["state"]
    assert abs(state["north_m"] - 30.0) < 3.0 and abs(state["east_m"] + 10.0) < 3.0 and abs(state["alt_m"] - 12) < 1

    home = vehicle.sim.environment.home
    lat, lon = offset_position(home.lat_deg, home.lon_deg, 10.0, 10.0)
    assert executor.call("flight.fly_to", {"lat": lat, "lon": lon}).status == "ok"  # altitude kept
    hovered = executor.call("flight.hover", {"duration_s": 3})
    assert hovered.status == "ok" and hovered.output["state"]["mode"] == "hold"

    dropped = executor.call("flight.deploy_payload", {"payload": "water"})
    assert dropped.status == "ok" and "water" in dropped.output["reason"]
    assert vehicle.sim.payload_released

    status = executor.call("flight.status", {})
    assert status.status == "ok" and status.output["armed"] and status.output["landed_state"] == "in_air"

    landed = executor.call("flight.land", {"offset_m": 0.0})
    assert landed.status == "ok", landed.error
    assert not landed.output["state"]["armed"] and abs(landed.output["state"]["alt_m"]) < 0.3
    assert math.hypot(landed.output["state"]["north_m"] - 10.0, landed.output["state"]["east_m"] - 10.0) < 2.0


def test_denials_are_errors_with_the_reason_and_scopes_are_enforced(executor, vehicle):
    early = executor.call("flight.rtl", {})
    assert early.status == "error" and "rtl denied" in early.error and "not flying" in early.error

    guest = Caller(id="guest", scopes=frozenset({"flight:read"}))
    refused = executor.call("flight.takeoff", {"altitude_m": 5}, caller=guest)
    assert refused.status == "denied" and "flight:command" in refused.error
    assert not vehicle.sim.armed  # nothing reached the vehicle
    commander = Caller(id="commander", scopes=frozenset({"flight:command"}))
    assert executor.call("flight.deploy_payload", {}, caller=commander).status == "denied"
    assert executor.call("flight.status", {}, caller=guest).status == "ok"

    vehicle.params.set("GF_MAX_HOR_DIST", 40.0)
    assert executor.call("flight.takeoff", {}).status == "ok"
    far = executor.call("flight.fly_to", {"north_m": 100.0, "east_m": 0.0})
    assert far.status == "error" and "denied" in far.error and "fence" in far.error
    assert executor.call("flight.hold", {}).status == "ok"

    world = executor.call("flight.fly_to", {"target_id": "P-12"})
    assert world.status == "error" and NEEDS_WORLD_MODEL in world.error
    both = executor.call("flight.fly_to", {"lat": 21.4, "lon": 39.9, "north_m": 1.0, "east_m": 1.0})
    assert both.status == "error" and "exactly one destination" in both.error
    bad = executor.call("flight.takeoff", {"altitude_m": -5})
    assert bad.status == "error" and "invalid arguments" in bad.error


def test_targets_are_found_through_the_resolver_and_landing_stops_short_of_them(vehicle):
    home = vehicle.sim.environment.home
    person = offset_position(home.lat_deg, home.lon_deg, 30.0, 0.0)
    known = {"P-12": person}
    registry = ToolRegistry()
    register_flight_tools(
        registry, lambda: VehicleClient.connect(vehicle.address, timeout_s=CONNECT_S), targets=known.get
    )
    with ToolExecutor(registry, default_caller=PILOT) as ex:
        assert ex.call("flight.takeoff", {"altitude_m": 10}).status == "ok"
        unknown = ex.call("flight.fly_to", {"target_id": "P-99"})
        assert unknown.status == "error" and "no object 'P-99' in the world model" in (unknown.error or "")
        landed = ex.call("flight.land", {"target_id": "P-12", "offset_m": 5.0})
        assert landed.status == "ok", landed.error
        state = landed.output["state"]
        # came from home (south of the person): touched down about 5 m south of them, not on them
        assert abs(state["north_m"] - 25.0) < 2.0 and abs(state["east_m"]) < 2.0


def test_beside_puts_the_point_between_the_aircraft_and_the_target():
    lat, lon = offset_position(21.4133, 39.8933, 0.0, 40.0)  # target 40 m east of the aircraft
    aircraft = Telemetry(connected=True, lat_deg=21.4133, lon_deg=39.8933)
    north, east = local_offset(21.4133, 39.8933, *beside(aircraft, lat, lon, 5.0))
    assert abs(north) < 1e-6 and abs(east - 35.0) < 1e-6
    assert beside(aircraft, lat, lon, 0.0) == (lat, lon)
    north, east = local_offset(lat, lon, *beside(Telemetry(connected=True), lat, lon, 5.0))  # position unknown: south
    assert abs(north + 5.0) < 1e-6 and abs(east) < 1e-6


def test_a_mission_through_the_executor(executor, vehicle):
    home = vehicle.sim.environment.home
    points = [offset_position(home.lat_deg, home.lon_deg, n, e) for n, e in [(25.0, 0.0), (25.0, 25.0)]]
    items = [{"command": 22, "lat": 0.0, "lon": 0.0, "alt": 8.0}]  # take-off here (lat/lon 0)
    items += [{"command": 16, "lat": lat, "lon": lon, "alt": 10.0} for lat, lon in points]
    items += [{"command": 20, "frame": 2}]  # return to launch: no position
    up = executor.call("flight.upload_mission", {"items": items})
    assert up.status == "ok", up.error
    assert up.output["status"] == "ok" and up.output["count"] == 4 and up.output["result"] == "MAV_MISSION_ACCEPTED"
    flown = executor.call("flight.start_mission", {})
    assert flown.status == "ok", flown.error
    assert flown.output["state"]["mission_state"] == "complete" and flown.output["reached"] is True
    assert vehicle.mode.name == "RTL"  # the last item handed over to Return
    bad = executor.call("flight.upload_mission", {"items": [{"command": 16, "frame": 2, "lat": 1.0, "lon": 2.0}]})
    assert bad.status == "error" and "frame 2 has no position" in bad.error
    refused = executor.call("flight.upload_mission", {"items": [{"command": 18, "lat": 21.4, "lon": 39.9}]})
    assert refused.status == "error" and "MAV_MISSION_UNSUPPORTED" in refused.error
    guest = Caller(id="guest", scopes=frozenset({"flight:read"}))
    assert executor.call("flight.start_mission", {}, caller=guest).status == "denied"


def test_the_tools_are_guarded_for_flying():
    async def never():
        raise AssertionError("not connected in this test")

    specs = {s.name: s for s in flight_tools(never)}
    mission_tools = {
        "flight.upload_mission",
        "flight.start_mission",
        "flight.set_fence",
        "flight.inject_failure",
    }  # no DSL action: whole plans, limits, rehearsed failures
    assert set(FLIGHT_ACTIONS.values()) | {"flight.hold", "flight.status"} | mission_tools == set(specs)
    for name, spec in specs.items():
        assert not spec.idempotent and spec.retry.attempts == 1 and spec.cache_ttl_s is None
        assert spec.is_async and spec.timeout_s == TIMEOUTS_S[name]
        expected = {
            "flight.deploy_payload": "flight:payload",
            "flight.status": "flight:read",
            "flight.inject_failure": "flight:fault",
        }.get(name, "flight:command")
        assert spec.scopes == (expected,)
    flying = ("flight.takeoff", "flight.fly_to", "flight.orbit", "flight.rtl", "flight.start_mission")
    assert all((specs[n].timeout_s or 0) >= 180 for n in flying)


def test_a_factory_that_cannot_connect_is_an_error():
    registry = ToolRegistry()
    register_flight_tools(registry, lambda: VehicleClient.connect(("127.0.0.1", free_udp_port()), timeout_s=0.2))
    with _closing(ToolExecutor(registry, default_caller=PILOT)) as ex:
        result = ex.call("flight.hold", {})
    assert result.status == "error" and "cannot connect to the vehicle" in result.error


class _closing:
    def __init__(self, ex):
        self.ex = ex

    def __enter__(self):
        return self.ex

    def __exit__(self, *exc):
        self.ex.close()


# --- the schemas accept exactly what the mission DSL sends ------------------------------------------------------


def dsl_examples():
    """Argument dicts as the mission DSL sends them (``step_args``: by alias, None left out, defaults in)."""
    center = mission.LatLon(lat=21.4141, lon=39.8942)
    cases: dict[str, list[BaseModel]] = {
        "takeoff": [mission.TakeoffArgs(), mission.TakeoffArgs(altitude_m=25)],
        "fly_to": [
            mission.FlyToArgs(lat=21.414, lon=39.894),
            mission.FlyToArgs(lat=21.414, lon=39.894, alt_m=30, speed_mps=8.5),
            mission.FlyToArgs(north_m=-120, east_m=40.5, alt_m=0),
            mission.FlyToArgs(target_id="P-12", alt_m=15, speed_mps=3),
        ],
        "orbit": [
            mission.OrbitArgs(center=center, radius_m=20),
            mission.OrbitArgs(target_id="P-3", radius_m=12.5, turns=2, alt_m=18),
        ],
        "hover": [mission.HoverArgs(duration_s=30)],
        "land": [
            mission.LandArgs(),
            mission.LandArgs(lat=21.4135, lon=39.8935),
            mission.LandArgs(target_id="P-7", offset_m=5),
        ],
        "rtl": [mission.NoArgs()],
        "deploy_payload": [mission.DeployPayloadArgs(), mission.DeployPayloadArgs(payload="water")],
    }
    for action, models in cases.items():
        step_model = mission.STEP_MODELS[action]
        for args in models:
            step = step_model.model_validate({"id": "s", "action": action, "args": args.model_dump()})
            yield action, mission.step_args(step)


def survey_legs():
    """The ``flight.fly_to`` calls a survey step makes."""
    calls = []

    class Ok:
        status, output, error = "ok", None, None

    def dispatch(tool, args, timeout_s):
        calls.append((tool, args))
        return Ok()

    step = mission.SurveyStep.model_validate(
        {
            "id": "sweep",
            "action": "survey",
            "args": {
                "polygon": [
                    {"lat": 21.413, "lon": 39.893},
                    {"lat": 21.414, "lon": 39.893},
                    {"lat": 21.414, "lon": 39.894},
                ],
                "altitude_m": 30,
                "spacing_m": 40,
                "speed_mps": 6,
            },
        }
    )
    env = Environment(dispatch=dispatch)
    perform(step, prepare(step, {}, env), {}, env)
    assert calls
    return calls


@pytest.fixture(scope="module")
def specs():
    async def never():
        raise AssertionError("no vehicle in this test")

    return {s.name: s for s in flight_tools(never)}


def test_every_flight_action_has_its_tool(specs):
    for action, tool in FLIGHT_ACTIONS.items():
        assert tool in specs, action
    assert set(FLIGHT_ACTIONS) - {"survey"} == set(ARGS_MODELS)


def test_tool_schemas_accept_what_the_dsl_sends(specs):
    seen = set()
    for action, args in dsl_examples():
        jsonschema.Draft202012Validator(specs[FLIGHT_ACTIONS[action]].input_schema).validate(args)
        seen.add(action)
    for tool, args in survey_legs():
        assert tool == "flight.fly_to"
        assert set(args) == {"lat", "lon", "alt_m", "speed_mps"}
        jsonschema.Draft202012Validator(specs[tool].input_schema).validate(args)
    assert seen == set(ARGS_MODELS)


def test_the_dsl_arguments_reach_the_client_as_meant():
    """Every DSL argument dict passes the executor's validation and reaches the right client call."""
    calls = []
    telemetry = Telemetry(connected=True, armed=True, mode="hold")

    class Recorder:
        closed = False

        def __init__(self):
            self.telemetry = telemetry

        def __getattr__(self, name):
            async def record(*args, **kwargs):
                calls.append((name, args, kwargs))
                return FlightResult(action=name, status="ok", elapsed_s=0.0, state=telemetry)

            return record

    async def factory():
        return Recorder()

    registry = ToolRegistry()
    register_flight_tools(registry, factory)
    with _closing(ToolExecutor(registry, default_caller=PILOT)) as ex:
        for action, args in dsl_examples():
            calls.clear()
            result = ex.call(FLIGHT_ACTIONS[action], args)
            if "target_id" in args:
                assert result.status == "error" and NEEDS_WORLD_MODEL in result.error, (action, args)
                assert not calls
                continue
            assert result.status == "ok", (action, args, result.error)
            names = [c[0] for c in calls]
            expected = {
                "takeoff": ["takeoff"],
                "fly_to": ["goto_local" if "north_m" in args else "goto"],
                "orbit": ["orbit"],
                "hover": ["hover"],
                "land": ["goto", "land"] if "lat" in args else ["land"],
                "rtl": ["rtl"],
                "deploy_payload": ["deploy_payload"],
            }[action]
            assert names == expected, (action, args, names)
        fly = ex.call("flight.fly_to", {"lat": 21.414, "lon": 39.894, "alt_m": 30, "speed_mps": 8.5})
        assert fly.status == "ok"
        assert calls[-1][1] == (21.414, 39.894, 30) and calls[-1][2]["speed_mps"] == 8.5
        orbit = ex.call("flight.orbit", {"center": {"lat": 21.4, "lon": 39.9}, "radius_m": 20, "turns": 2})
        assert orbit.status == "ok"
        assert calls[-1][1] == (21.4, 39.9, 20) and calls[-1][2] == {"turns": 2, "alt_m": None}


def test_asyncio_callers_share_the_client(executor):
    async def two():
        first = await executor.acall("flight.status", {})
        second = await executor.acall("flight.status", {})
        return first, second

    first, second = asyncio.run(two())
    assert first.status == second.status == "ok"
    assert executor.call("flight.status", {}).status == "ok"  # the executor's own loop: the same client


def test_set_fence_refuses_a_fence_given_two_ways_and_half_a_circle():
    async def never():
        raise AssertionError("not connected: the arguments are refused first")

    (fence,) = [s for s in flight_tools(never) if s.name == "flight.set_fence"]
    executor = ToolExecutor(ToolRegistry(), default_caller=Caller(id="t", scopes=frozenset({"flight:*"})))
    executor.registry.register(fence)
    both = executor.call(
        "flight.set_fence",
        {"max_alt_m": 25, "polygon": [{"lat": 21.4, "lon": 39.8}] * 3, "center": {"lat": 21.4, "lon": 39.8},
         "radius_m": 100},
    )  # fmt: skip
    half = executor.call("flight.set_fence", {"max_alt_m": 25, "center": {"lat": 21.4, "lon": 39.8}})
    executor.close()
    assert both.status == "error" and "not both" in (both.error or "")
    assert half.status == "error" and "both center and radius_m" in (half.error or "")
