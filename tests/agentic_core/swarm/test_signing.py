"""Hostile tests of signed swarm messages: each way to forge, replay, age or garble a message is refused, and every
refusal is audited."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from agentic_core.contracts.errors import InputError
from agentic_core.contracts.swarm import Rejection
from agentic_core.swarm.signing import Guard, JsonlAudit, MemoryAudit, Refused, Sealer, SwarmKey
from tests.agentic_core.swarm.conftest import Clock


def _guard(key: SwarmKey, clock: Clock, **kwargs: object) -> tuple[Guard, MemoryAudit]:
    audit = MemoryAudit()
    return Guard(key, "uav-1", audit=audit, clock=clock, **kwargs), audit  # type: ignore[arg-type]


def _refused(guard: Guard, raw: object) -> str:
    with pytest.raises(Refused) as caught:
        guard.parse(raw) if isinstance(raw, str | dict) else guard.check(raw)  # type: ignore[arg-type]
    return caught.value.rejection.reason


def test_a_genuine_message_passes_once_and_its_replay_is_refused(key: SwarmKey, clock: Clock) -> None:
    guard, audit = _guard(key, clock)
    message = Sealer(key, "ground", clock=clock).seal("award", {"task": "T-1", "winner": "uav-1"})
    assert guard.check(message) == message
    assert _refused(guard, message) == "replayed"
    assert _refused(guard, message.model_dump_json()) == "replayed"  # the same bytes off the wire
    assert audit.reasons() == ["replayed", "replayed"]
    assert audit.rejections[0].nonce == message.nonce and audit.rejections[0].sender == "ground"


@pytest.mark.parametrize(
    "field, value",
    [
        ("body", {"task": "T-1", "winner": "uav-9"}),
        ("sender", "uav-9"),
        ("kind", "cancel"),
        ("timestamp", 1000.5),
        ("nonce", "ab" * 16),
        ("recipient", None),
        ("conversation", "other"),
    ],
)
def test_changing_any_signed_field_makes_it_forged(key: SwarmKey, clock: Clock, field: str, value: object) -> None:
    guard, audit = _guard(key, clock)
    genuine = Sealer(key, "ground", clock=clock).seal("award", {"task": "T-1", "winner": "uav-1"}, recipient="uav-1")
    assert getattr(genuine, field) != value
    assert _refused(guard, genuine.model_copy(update={field: value})) == "forged"
    assert audit.reasons() == ["forged"]
    assert guard.check(genuine) == genuine  # a forgery burns no nonce of the genuine message


def test_another_swarms_key_or_an_empty_signature_is_forged(key: SwarmKey, clock: Clock) -> None:
    guard, audit = _guard(key, clock)
    other = Sealer(SwarmKey.generate("mina"), "ground", clock=clock).seal("award", {"task": "T-1"})
    same_secret_other_swarm = SwarmKey("arafat", b"k" * 32), SwarmKey("mina", b"k" * 32)
    crossed = Sealer(same_secret_other_swarm[0], "ground", clock=clock).seal("award", {})
    assert _refused(guard, other) == "forged"
    assert _refused(guard, other.model_copy(update={"signature": ""})) == "forged"
    assert _refused(Guard(same_secret_other_swarm[1], "uav-1", audit=audit, clock=clock), crossed) == "forged"
    assert audit.reasons() == ["forged", "forged", "forged"]


@pytest.mark.parametrize("skew_s", [-31.0, 31.0, -1e9, 1e9])
def test_a_message_too_old_or_from_the_future_is_stale(key: SwarmKey, clock: Clock, skew_s: float) -> None:
    guard, audit = _guard(key, clock, max_age_s=30.0)
    sent_at = Clock(clock.now + skew_s)
    assert _refused(guard, Sealer(key, "ground", clock=sent_at).seal("cfp", {})) == "stale"
    assert audit.reasons() == ["stale"]


def test_a_replay_after_the_window_is_still_refused_as_stale(key: SwarmKey, clock: Clock) -> None:
    guard, audit = _guard(key, clock, max_age_s=30.0)
    message = Sealer(key, "ground", clock=clock).seal("award", {})
    guard.check(message)
    clock.now += 31.0  # the nonce is forgotten now: the age refuses the replay instead
    assert _refused(guard, message) == "stale"
    assert audit.reasons() == ["stale"]


def test_a_flood_of_genuine_messages_cannot_open_a_replay(key: SwarmKey, clock: Clock) -> None:
    guard, audit = _guard(key, clock, max_nonces=10)
    sealer = Sealer(key, "ground", clock=clock)
    first = sealer.seal("cfp", {})
    guard.check(first)
    for _ in range(20):
        clock.now += 0.01
        guard.check(sealer.seal("cfp", {}))
    assert _refused(guard, first) in {"replayed", "stale"}  # evicted from memory, but never accepted twice
    assert len(audit.reasons()) == 1


@pytest.mark.parametrize(
    "raw",
    ["not json", "[]", "{}", json.dumps({"kind": "award", "sender": "ground"}), "{" * 5000, '{"kind": "nuke"}'],
)
def test_garbage_is_refused_as_malformed_not_a_traceback(key: SwarmKey, clock: Clock, raw: str) -> None:
    guard, audit = _guard(key, clock)
    assert _refused(guard, raw) == "malformed"
    assert audit.reasons() == ["malformed"] and len(audit.rejections[0].detail) <= 200


def test_a_message_to_another_member_or_from_a_stranger_is_refused(key: SwarmKey, clock: Clock) -> None:
    guard, audit = _guard(key, clock, members={"ground", "uav-1", "uav-2"})
    assert _refused(guard, Sealer(key, "ground", clock=clock).seal("award", {}, recipient="uav-2")) == "misaddressed"
    assert _refused(guard, Sealer(key, "uav-7", clock=clock).seal("bid", {})) == "unknown_sender"
    assert audit.reasons() == ["misaddressed", "unknown_sender"]


def test_refusals_are_written_to_a_jsonl_audit(key: SwarmKey, clock: Clock, tmp_path: Path) -> None:
    path = tmp_path / "swarm_audit.jsonl"
    guard = Guard(key, "uav-1", audit=JsonlAudit(path), clock=clock)
    message = Sealer(key, "ground", clock=clock).seal("award", {})
    guard.check(message)
    for forged in (message, message.model_copy(update={"signature": "0" * 64})):
        with pytest.raises(Refused):
            guard.check(forged)
    lines = [Rejection.model_validate_json(line) for line in path.read_text().splitlines()]
    assert [(r.reason, r.receiver, r.kind) for r in lines] == [
        ("replayed", "uav-1", "award"),
        ("forged", "uav-1", "award"),
    ]


@pytest.mark.parametrize("value", [float("inf"), float("nan"), {"deep": [float("-inf")]}])
def test_a_body_json_cannot_carry_unchanged_is_refused_at_sealing(key: SwarmKey, value: object) -> None:
    with pytest.raises(ValueError, match="JSON compliant"):
        Sealer(key, "ground").seal("state", {"x": value})


def test_a_short_or_unreadable_key_is_an_input_error(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="at least 32"):
        SwarmKey("mina", b"short")
    (tmp_path / "key").write_text("zz")
    with pytest.raises(InputError, match="not a swarm key"):
        SwarmKey.from_file("mina", tmp_path / "key")
    (tmp_path / "key").write_text("ab" * 32)
    assert "ab" not in repr(SwarmKey.from_file("mina", tmp_path / "key"))


@settings(max_examples=60, deadline=None)
@given(
    body=st.dictionaries(
        st.text(max_size=8),
        st.one_of(st.integers(), st.floats(allow_nan=False, allow_infinity=False), st.text()),
        max_size=4,
    )
)
def test_any_body_survives_the_wire_and_any_bit_flip_of_its_signature_is_forged(body: dict[str, object]) -> None:
    key, clock = SwarmKey("mina", b"s" * 32), Clock()
    message = Sealer(key, "ground", clock=clock).seal("state", body)
    assert Guard(key, "uav-1", clock=clock).parse(message.model_dump_json()).body == message.body
    flipped = format(int(message.signature[0], 16) ^ 1, "x") + message.signature[1:]
    with pytest.raises(Refused, match="forged"):
        Guard(key, "uav-1", clock=clock).check(message.model_copy(update={"signature": flipped}))
