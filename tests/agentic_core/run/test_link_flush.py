"""A run over a link hears the vehicle's disarm in a HEARTBEAT between position messages: before it says where the
aircraft ended, the link backend hands its hooks one last sample of all the client heard, so the end is not
"in the air" for an aircraft on the ground."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import pytest

from agentic_core.contracts import TelemetrySample
from agentic_core.run.backends import LinkBackend
from agentic_core.run.stops import where_it_ended

pytestmark = pytest.mark.timeout(30)


def at(alt: float, *, armed: bool, landed: str) -> TelemetrySample:
    return TelemetrySample(time_s=77.9, lat_deg=21.4133, lon_deg=39.8933, alt_m=alt, north_m=0.3, east_m=0.0,
                           down_m=-alt, armed=armed, landed_state=landed)  # fmt: skip


class Client:
    """What the backend reads of a client: its hooks, and its telemetry as heard now."""

    def __init__(self) -> None:
        self.heard = at(0.0, armed=True, landed="landing")
        self.telemetry = SimpleNamespace(sample=lambda: self.heard)

    def on_sample(self, hook: Any) -> None:
        self.hook = hook

    def on_wire(self, tap: Any) -> None:
        raise AssertionError("no flight log was asked for")


def test_the_last_word_of_the_link_reaches_the_hooks_before_the_end_is_said() -> None:
    backend = LinkBackend("udp://127.0.0.1:14580")
    got: list[TelemetrySample] = []
    backend.on_sample(got.append)
    client = Client()
    backend.attach(client)  # type: ignore[arg-type]
    client.hook(client.heard)  # the last position message: touching down, still armed
    client.heard = at(0.0, armed=False, landed="landing")  # then the disarm's HEARTBEAT, with no position after it
    backend.flush()
    try:
        assert got[-1].armed is False
        assert where_it_ended(got[-1]).startswith("on the ground, disarmed")
    finally:
        backend.close()


def test_flush_without_a_client_or_anything_heard_does_nothing() -> None:
    backend = LinkBackend("udp://127.0.0.1:14580")
    got: list[TelemetrySample] = []
    backend.on_sample(got.append)
    backend.flush()  # never attached
    client = Client()
    client.telemetry = SimpleNamespace(sample=lambda: None)
    backend.attach(client)  # type: ignore[arg-type]
    backend.flush()  # attached, nothing heard yet
    backend.close()
    assert got == []
