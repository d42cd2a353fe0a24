"""The fence handed again to an armed vehicle over an unsigned link, as a resumed run does: the fence and limits it
already holds are kept (nothing sent that it would refuse), and a different fence is still refused, as it must be
without a signed link."""

from typing import Any

from flight.geodesy import offset_position
from flight.vehicle import VehicleClient
from tests.waiting import CONNECT_S

from .test_client import run


def test_an_armed_vehicle_keeps_the_fence_it_holds_and_refuses_another(vehicle: Any) -> None:
    home = vehicle.sim.environment.home
    centre = offset_position(home.lat_deg, home.lon_deg, 0.0, 0.0)
    elsewhere = offset_position(home.lat_deg, home.lon_deg, 30.0, 0.0)

    async def go() -> tuple[Any, Any, Any]:
        async with await VehicleClient.connect(vehicle.address, timeout_s=CONNECT_S) as client:
            first = await client.upload_fence(circle=(*centre, 150.0), max_alt_m=25.0, floor_m=2.0)
            assert first.ok, first
            assert (await client.arm()).ok
            assert (await client.takeoff(8.0)).ok
            again = await client.upload_fence(circle=(*centre, 150.0), max_alt_m=25.0, floor_m=2.0)
            other = await client.upload_fence(circle=(*elsewhere, 90.0), max_alt_m=25.0, floor_m=2.0)
            higher = await client.upload_fence(circle=(*centre, 150.0), max_alt_m=40.0, floor_m=2.0)
            return again, other, higher

    again, other, higher = run(go(), 60.0)
    assert again.status == "ok" and again.items == 1, again
    assert again.params == {"GF_MAX_VER_DIST": 25.0, "RTL_RETURN_ALT": 24.0, "GF_MIN_ALT": 2.0}
    assert other.status == "denied" and "signed" in (other.reason or ""), other
    assert higher.status == "denied" and "GF_MAX_VER_DIST" in (higher.reason or ""), higher
    (area,) = vehicle.navigator.fence.areas  # the vehicle still holds the first fence, untouched
    assert round(area.radius_m) == 150 and vehicle.params["GF_MAX_VER_DIST"] == 25.0
