"""Alert recipients and webhook hosts come from an allowlist in configuration: anything else is refused before a
byte leaves, as a result the agent sees and the audit log keeps, and never kept in the outbox as an alert."""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from tests.tools.builtin.conftest import Harness, MailServer
from tests.tools.builtin.local_http import LocalHTTPServer, Reply, text_reply
from tools.audit import MemoryAuditLog
from tools.builtin.allowlist import (
    DestinationRefused,
    allowed_recipients,
    check_recipients_allowed,
    destination_problems,
    recipient_allowed,
    webhook_hosts,
)
from tools.builtin.config import BuiltinConfig

MEDIC = "medical-team@example.org"


def mailing(config: BuiltinConfig, server: MailServer, **changes: Any) -> BuiltinConfig:
    """``config`` sending through ``server``, with only the medical team allowed unless ``changes`` say more."""
    base = {"smtp_host": server.host, "smtp_port": server.port, "smtp_starttls": False}
    return config.model_copy(update={**base, "alert_allow": [], "alert_recipients": [MEDIC], **changes})


def audited(harness: Harness, tool: str) -> list[Any]:
    assert isinstance(harness.executor.audit, MemoryAuditLog)
    return [r for r in harness.executor.audit.records if r.tool == tool]


def test_mail_to_an_address_off_the_allowlist_is_refused_and_nothing_is_sent_or_kept(
    config: BuiltinConfig, smtp_server: MailServer, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    tools = harness(mailing(config, smtp_server))
    cases: list[tuple[str, dict[str, Any]]] = [
        ("alerts.notify", {"subject": "Casualty at 21.41, 39.89", "body": "b", "to": "drop@evil.example"}),
        ("alerts.notify", {"subject": "s", "body": "b", "to": [MEDIC, "drop@evil.example"]}),  # one bad: none sent
        ("alerts.send_email", {"to": ["Medical Team <drop@evil.example>"], "subject": "s", "body": "b"}),
    ]
    for tool, args in cases:
        result = tools.call(tool, args)
        assert result.status == "error" and result.attempts == 1, result
        assert "drop@evil.example is not on the alert allowlist" in (result.error or "")
        assert "copy was kept" not in (result.error or "")  # a refused message is not an undelivered alert
        (record, *_) = audited(tools, tool)
        assert record.status == "error" and "alert allowlist" in (record.error or "")
    assert not smtp_server.inbox.envelopes
    assert not list(config.outbox_dir.glob("*")) if config.outbox_dir.exists() else True


def test_the_configured_medical_team_is_reached_by_default(
    config: BuiltinConfig, smtp_server: MailServer, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    tools = harness(mailing(config, smtp_server))
    named = tools.call("alerts.notify", {"subject": "s", "body": "b", "to": "Medical-Team@EXAMPLE.org"})
    defaulted = tools.call("alerts.notify", {"subject": "s", "body": "b"})
    assert named.ok and defaulted.ok, (named.error, defaulted.error)
    assert [e.rcpt_tos for e in smtp_server.inbox.envelopes] == [["Medical-Team@EXAMPLE.org"], [MEDIC]]


@pytest.mark.parametrize(
    "address",
    [
        "drop@evil.example",
        "medical-team@example.org.evil.example",  # the allowed domain as a prefix
        "medical-team@evil.example",
        "medical-team@example.org@evil.example",  # two @: the last domain is where it goes
        '"medical-team@example.org"@evil.example',
        "medical-team@sub.example.org",  # a domain entry allows that domain only, not its subdomains
        "",
    ],
)
def test_look_alike_addresses_are_refused(address: str) -> None:
    allowed = allowed_recipients(BuiltinConfig(alert_recipients=[MEDIC], alert_allow=["@ops.example.org"]))
    assert recipient_allowed(allowed, MEDIC) and recipient_allowed(allowed, "anyone@ops.example.org")
    assert not recipient_allowed(allowed, address)
    assert not recipient_allowed(allowed, address.replace("example.org", "ops.example.org"))


def test_an_allowlist_entry_lets_more_through_and_the_environment_sets_it() -> None:
    env = {
        "AGENTIC_UAV_ALERT_RECIPIENTS": MEDIC,
        "AGENTIC_UAV_ALERT_ALLOW": "duty@ops.example; @hospital.example",
        "AGENTIC_UAV_WEBHOOK_URL": "https://hooks.example/T0KEN",
        "AGENTIC_UAV_WEBHOOK_ALLOW": "backup.example, Ops.Example.",
        "AGENTIC_UAV_SMTP_HOST": "mail.example",
    }
    config = BuiltinConfig.from_env(env)
    check_recipients_allowed(config, [MEDIC, "duty@ops.example", "er@hospital.example"])
    with pytest.raises(DestinationRefused, match=re.escape("duty@elsewhere.example")):
        check_recipients_allowed(config, ["duty@elsewhere.example"])
    assert webhook_hosts(config) == ("hooks.example", "backup.example", "ops.example")


def test_with_no_mail_server_the_outbox_keeps_any_address(config: BuiltinConfig, harness: Callable[..., Any]) -> None:
    """Nothing leaves the machine without a mail server: the allowlist has nothing to guard (documented)."""
    result = harness(config.model_copy(update={"alert_allow": []})).call(
        "alerts.notify", {"subject": "s", "body": "b", "to": "drop@evil.example"}
    )
    assert result.ok and result.output["delivered_via"] == "outbox"


def test_a_webhook_host_off_the_allowlist_is_refused_and_never_contacted(
    config: BuiltinConfig, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    with LocalHTTPServer([text_reply("ok")]) as server:
        only_configured = config.model_copy(update={"webhook_allow": [], "webhook_url": "https://hooks.example/x"})
        tools = harness(only_configured)
        result = tools.call("alerts.webhook", {"payload": {"lat": 21.41, "lon": 39.89}, "url": server.url + "/x"})
        assert not server.requests
    assert result.status == "error" and result.attempts == 1
    assert "'127.0.0.1' is not on the webhook allowlist" in (result.error or "")
    assert "copy was kept" not in (result.error or "") and not list(config.outbox_dir.glob("*.json"))
    (record,) = audited(tools, "alerts.webhook")
    assert record.status == "error" and "webhook allowlist" in (record.error or "")


def test_the_configured_webhook_is_allowed_without_a_list(
    config: BuiltinConfig, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    with LocalHTTPServer([text_reply("ok")]) as server:
        tools = harness(config.model_copy(update={"webhook_allow": [], "webhook_url": server.url + "/hook"}))
        result = tools.call("alerts.notify", {"subject": "s", "body": "b", "channel": "webhook"})
        explicit = tools.call("alerts.webhook", {"payload": {"n": 1}, "url": server.url + "/other"})
    assert result.ok and explicit.ok, (result.error, explicit.error)
    assert [r.path for r in server.requests] == ["/hook", "/other"]


def test_a_redirect_off_the_allowed_hosts_is_refused_by_the_egress_policy(
    config: BuiltinConfig, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    """Allowed host, egress allowed too: its redirect to another host the webhook may not reach is not followed."""

    def answer(request: Any) -> Reply:
        return Reply(307, b"", {"Location": f"http://localhost:{port}/steal"})

    with LocalHTTPServer(answer) as server:
        port = server.url.rsplit(":", 1)[1]
        tools = harness(config.model_copy(update={"egress_allow": ["127.0.0.1", "localhost"]}))
        result = tools.call("alerts.webhook", {"payload": {"n": 1}, "url": server.url + "/hook"})
    assert result.status == "error" and "localhost is not an allowed host" in (result.error or "")
    assert "AGENTIC_UAV_WEBHOOK_ALLOW" in (result.error or "")
    assert [r.path for r in server.requests] == ["/hook"]


def test_what_a_plan_review_sees_of_literal_destinations(tmp_path: Path) -> None:
    config = BuiltinConfig(smtp_host="mail.example", alert_recipients=[MEDIC], webhook_url="https://hooks.example/x")
    assert destination_problems(config, "alerts.notify", {"to": "drop@evil.example", "channel": "email"}) == [
        "drop@evil.example is not on the alert allowlist (AGENTIC_UAV_ALERT_RECIPIENTS, AGENTIC_UAV_ALERT_ALLOW)"
    ]
    assert destination_problems(config, "alerts.webhook", {"url": "https://collector.example/x"}) == [
        "the webhook host 'collector.example' is not on the webhook allowlist "
        "(AGENTIC_UAV_WEBHOOK_URL, AGENTIC_UAV_WEBHOOK_ALLOW)"
    ]
    assert destination_problems(config, "alerts.notify", {"to": "${params.team}"}) == []  # the tool checks it
    assert destination_problems(config, "alerts.notify", {"to": "drop@evil.example", "channel": "log"}) == []
    assert destination_problems(config, "alerts.webhook", {"url": "https://hooks.example/y"}) == []
