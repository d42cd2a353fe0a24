""":class:`flight.signing.Signer` applies MAVLink 2's replay rules itself (hashing each frame once, and only after
the signature is good): for well-signed frames it accepts exactly what pymavlink's own ``check_signature`` accepts,
whatever the order of streams and timestamps; a forged frame never moves a stream's clock."""

from __future__ import annotations

from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import common as mavlink2

from flight.signing import Signer, Verdict

KEY = bytes(range(32))
NOW = 10**12


def signed_frame(system: int, link: int, timestamp: int, key: bytes = KEY) -> Any:
    """A HEARTBEAT from ``system`` signed on ``link`` at ``timestamp``, parsed back as a receiver sees it."""
    mav = mavlink2.MAVLink(None, srcSystem=system, srcComponent=1)
    mav.signing.secret_key, mav.signing.sign_outgoing = key, True
    mav.signing.link_id, mav.signing.timestamp = link, timestamp
    buf = mavlink2.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3).pack(mav)
    return mavlink2.MAVLink(None).decode(bytearray(buf))


frames = st.lists(
    st.tuples(st.integers(1, 3), st.integers(0, 2), st.integers(NOW - 8_000_000, NOW + 50)), min_size=1, max_size=40
)


@settings(max_examples=60, deadline=None)
@given(frames)
def test_the_replay_rule_is_pymavlinks(sequence: list[tuple[int, int, int]]) -> None:
    ours = Signer(KEY, timestamp=NOW)
    ours.state.timestamp = NOW  # not the wall clock: both judges start from the same time
    reference = mavlink2.MAVLink(None)
    reference.signing.secret_key, reference.signing.timestamp = KEY, NOW
    for system, link, timestamp in sequence:
        msg = signed_frame(system, link, timestamp)
        expected = reference.check_signature(msg.get_msgbuf(), system, 1)
        assert (ours.check(msg) == Verdict.SIGNED) == expected, (system, link, timestamp)
    assert ours.state.timestamp == reference.signing.timestamp


def test_a_forged_frame_does_not_move_the_streams_clock() -> None:
    ours = Signer(KEY, timestamp=NOW)
    ours.state.timestamp = NOW
    assert ours.check(signed_frame(1, 0, NOW + 10)) == Verdict.SIGNED
    assert ours.check(signed_frame(1, 0, NOW + 10**9, key=bytes(32))) == Verdict.BAD_SIGNATURE  # far future, forged
    assert ours.check(signed_frame(1, 0, NOW + 11)) == Verdict.SIGNED  # the real sender goes on
    assert ours.check(signed_frame(1, 0, NOW + 11)) == Verdict.REPLAYED
    assert ours.counters.as_dict()["signed"] == 2
