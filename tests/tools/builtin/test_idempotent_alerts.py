"""Side-effect built-ins under idempotency keys: marked as acting, replayed instead of sent again, and the key handed
on so receivers can dedupe (the e-mail's Message-ID, the webhook's and HTTP tools' ``Idempotency-Key`` header)."""

from __future__ import annotations

import doctest
import email
import email.policy
import hashlib
import importlib
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import httpx
import pytest

from flight.tools import flight_tools
from tools import ToolExecutor, ToolRegistry
from tools.builtin import BuiltinConfig, notify, register_builtins
from tools.builtin.mail import keyed_message_id
from tools.http_endpoint import HttpEndpoint, http_tool

from .conftest import ROOT, Harness, MailServer
from .local_http import LocalHTTPServer, Reply

KEY = "run-3:alert_ops:0"
ACTING = {"alerts.send_email", "alerts.webhook", "alerts.notify", "incidents.log"}


def settings(config: BuiltinConfig, **changes: object) -> BuiltinConfig:
    return BuiltinConfig.model_validate({**config.model_dump(), **changes})


def test_the_tools_that_act_outside_the_run_are_marked(config: BuiltinConfig) -> None:
    registry = ToolRegistry()
    names = register_builtins(registry, config)
    assert {n for n in names if registry.get(n).side_effects} == ACTING
    assert {n for n in names if registry.describe(n).side_effects} == ACTING

    async def never() -> Any:
        raise AssertionError("not connected in this test")

    flight = {spec.name: spec.side_effects for spec in flight_tools(never)}
    assert [name for name, acts in flight.items() if acts] == ["flight.deploy_payload"]


def test_a_notify_email_is_written_once_per_key(
    config: BuiltinConfig, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    tools = harness(config)
    args = {"subject": "Collapsed pilgrim", "body": "Motionless for 40 s."}
    first = tools.executor.call("alerts.notify", args, idempotency_key=KEY)
    again = tools.executor.call("alerts.notify", args, idempotency_key=KEY)
    assert first.ok and again.replayed and again.output == first.output
    (eml,) = sorted(config.outbox_dir.glob("*.eml"))
    message = email.message_from_bytes(eml.read_bytes(), policy=email.policy.default)
    assert message["Message-ID"] == first.output["message_id"] == keyed_message_id(config, "alerts.notify", KEY)


def test_the_message_id_is_the_same_for_every_rerun_of_the_action(config: BuiltinConfig) -> None:
    """Even when the executor's record is lost (a fresh executor, no shared log), the mail server sees one id."""
    registry = ToolRegistry()
    register_builtins(registry, config)
    ids = []
    for _ in range(2):
        with ToolExecutor(registry, default_caller=ROOT) as executor:
            result = executor.call("alerts.notify", {"subject": "s", "body": "b"}, idempotency_key=KEY)
            ids.append(result.output["message_id"])
    other = notify(config, "s", "b", idempotency_key="run-3:alert_ops:1").message_id
    unkeyed = {notify(config, "s", "b").message_id for _ in range(2)}
    assert ids[0] == ids[1] and other != ids[0] and len(unkeyed) == 2 and ids[0] not in unkeyed
    assert keyed_message_id(config, "alerts.send_email", KEY) != ids[0]  # another tool's mail is another message


def test_an_smtp_mail_carries_the_keyed_message_id_and_is_sent_once(
    config: BuiltinConfig, smtp_server: MailServer, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    tools = harness(settings(config, smtp_host=smtp_server.host, smtp_port=smtp_server.port, smtp_starttls=False))
    args = {"to": ["ops@team.example"], "subject": "Fire", "body": "Tent 12"}
    for _ in range(3):
        assert tools.executor.call("alerts.send_email", args, idempotency_key=KEY).ok
    (envelope,) = smtp_server.inbox.envelopes
    content = envelope.content if isinstance(envelope.content, bytes) else str(envelope.content).encode()
    message = email.message_from_bytes(content, policy=email.policy.default)
    assert message["Message-ID"] == keyed_message_id(config, "alerts.send_email", KEY)


@pytest.mark.parametrize(
    ("key", "header"),
    [
        (KEY, KEY),
        ("réunion:étape:0", hashlib.sha256("réunion:étape:0".encode()).hexdigest()),  # not plain ASCII: its digest
        ("a\r\nX-Injected: 1", hashlib.sha256(b"a\r\nX-Injected: 1").hexdigest()),  # no header splitting
    ],
)
def test_a_webhook_sends_the_key_as_idempotency_key(
    key: str, header: str, config: BuiltinConfig, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    with LocalHTTPServer([Reply(200)]) as server:
        tools = harness(config)
        sent = tools.executor.call("alerts.webhook", {"payload": {"n": 1}, "url": server.url}, idempotency_key=key)
        again = tools.executor.call("alerts.webhook", {"payload": {"n": 1}, "url": server.url}, idempotency_key=key)
        plain = tools.executor.call("alerts.webhook", {"payload": {"n": 2}, "url": server.url})
    assert sent.ok and again.replayed and plain.ok
    keyed, unkeyed = server.requests
    assert keyed.headers["idempotency-key"] == header and "x-injected" not in keyed.headers
    assert "idempotency-key" not in unkeyed.headers
    assert json.loads(keyed.body) == {"n": 1}


def test_a_notify_webhook_sends_the_key(config: BuiltinConfig, harness: Callable[[BuiltinConfig], Harness]) -> None:
    with LocalHTTPServer([Reply(200)]) as server:
        tools = harness(settings(config, webhook_url=server.url))
        result = tools.executor.call(
            "alerts.notify", {"subject": "s", "body": "b", "channel": "webhook"}, idempotency_key=KEY
        )
    assert result.ok and [r.headers.get("idempotency-key") for r in server.requests] == [KEY]


def test_an_http_endpoint_tool_sends_the_key() -> None:
    seen: list[httpx.Request] = []

    def answer(request: httpx.Request) -> httpx.Response:
        seen.append(request)
        return httpx.Response(201, json={"ticket": len(seen)})

    endpoint = HttpEndpoint(name="dispatch.create_ticket", method="POST", url="https://desk.example/tickets",
                            side_effects=True)  # fmt: skip
    registry = ToolRegistry()
    registry.register(http_tool(endpoint, transport=httpx.MockTransport(answer)))
    assert registry.describe("dispatch.create_ticket").side_effects
    with ToolExecutor(registry) as executor:
        first = executor.call("dispatch.create_ticket", {}, idempotency_key=KEY)
        again = executor.call("dispatch.create_ticket", {}, idempotency_key=KEY)
        plain = executor.call("dispatch.create_ticket", {})
    assert (first.output, again.output, again.replayed, plain.output) == (
        {"ticket": 1},
        {"ticket": 1},
        True,
        {"ticket": 2},
    )
    assert [r.headers.get("Idempotency-Key") for r in seen] == [KEY, None]


def test_the_incident_log_records_one_incident_per_key(
    config: BuiltinConfig, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    tools = harness(config)
    args = {"kind": "fire", "severity": "high", "description": "Tent 12"}
    results = [tools.executor.call("incidents.log", args, idempotency_key=KEY) for _ in range(3)]
    found = tools.call("incidents.query", {})
    assert [r.replayed for r in results] == [False, True, True]
    assert {r.output["id"] for r in results} == {found.output["incidents"][0]["id"]} and found.output["count"] == 1


@pytest.mark.parametrize("name", ["tools.idempotency", "tools.audit_index", "tools.builtin.mail"])
def test_docstring_examples(name: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0
