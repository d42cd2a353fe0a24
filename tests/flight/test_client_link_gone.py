"""A flight action waiting on a vehicle that has gone silent gives up once nothing has been heard for the client's
``link_silent_s``, saying the link is gone, rather than waiting out the action's own timeout (a return home waited
100 s for a vehicle killed under it)."""

import asyncio
import time
from typing import Any

from flight.client.core import LINK_SILENT_S
from flight.vehicle import VehicleClient
from tests.waiting import CONNECT_S, wait_for_async

from .test_client import run


def test_a_return_home_on_a_vehicle_gone_silent_ends_after_the_silence_bound(vehicle):
    async def fly():
        async with await VehicleClient.connect(vehicle.address, timeout_s=CONNECT_S) as client:
            assert client.link_silent_s == LINK_SILENT_S and client.silent_s < 2.0
            client.link_silent_s = 2.0
            assert (await client.arm()).ok
            assert (await client.takeoff(15.0)).ok
            task = asyncio.create_task(client.rtl(timeout_s=100.0))
            await wait_for_async(lambda: client.telemetry.mode == "rtl", 5, what="the vehicle returning")
            vehicle.stop()  # killed: the socket stays open, nothing more comes
            began = time.monotonic()
            result: Any = await task
            took = time.monotonic() - began
            assert result.status == "timeout" and not result.reached
            assert "the link is gone: nothing heard from the vehicle for" in result.reason
            assert 1.5 <= took < 5.0, took  # the silence bound, not the return's 100 s
            assert client.silent_s >= 2.0

    run(fly(), timeout_s=60.0)


def test_a_vehicle_that_keeps_talking_is_not_given_up_on(vehicle):
    async def fly():
        async with await VehicleClient.connect(vehicle.address, timeout_s=CONNECT_S) as client:
            client.link_silent_s = 0.5  # shorter than any action here: only real silence may end one
            assert (await client.arm()).ok
            up: Any = await client.takeoff(8.0)
            assert up.status == "ok" and up.reached, up.reason

    run(fly(), timeout_s=60.0)
