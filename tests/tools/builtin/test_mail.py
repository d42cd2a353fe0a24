"""alerts.send_email: SMTP delivery (plain and STARTTLS with login) against a local aiosmtpd server, the outbox
fallback, and which failures are retried."""

from __future__ import annotations

import email
import email.policy
from collections.abc import Callable
from email.message import EmailMessage
from pathlib import Path

import pytest

from tools.builtin import BuiltinConfig
from tools.builtin.mail import send_email

from .conftest import SMTP_PASSWORD, SMTP_USER, Harness, MailServer
from .local_http import free_port

PNG = b"\x89PNG\r\n\x1a\n" + bytes(range(256)) * 4  # binary content that must survive base64


def parse(raw: bytes) -> EmailMessage:
    message = email.message_from_bytes(raw, policy=email.policy.default)
    assert isinstance(message, EmailMessage)
    return message


def attachments(message: EmailMessage) -> dict[str, bytes]:
    found = {}
    for part in message.iter_attachments():
        payload = part.get_payload(decode=True)
        assert isinstance(payload, bytes)
        found[str(part.get_filename())] = payload
    return found


@pytest.fixture
def snapshot(tmp_path: Path) -> Path:
    path = tmp_path / "snapshot-annotated.png"
    path.write_bytes(PNG)
    return path


def smtp_config(config: BuiltinConfig, server: MailServer, **changes: object) -> BuiltinConfig:
    """``config`` sending through ``server`` (plain SMTP unless ``changes`` say otherwise)."""
    values = {"smtp_host": server.host, "smtp_port": server.port, "smtp_starttls": False}
    return BuiltinConfig.model_validate(
        {**config.model_dump(), "smtp_from": "UAV Ops <uav@ops.example>", **values, **changes}
    )


def test_smtp_delivers_subject_body_and_attachment(
    config: BuiltinConfig, smtp_server: MailServer, snapshot: Path, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    tools = harness(smtp_config(config, smtp_server))
    result = tools.call(
        "alerts.send_email",
        {"to": ["medic@team.example"], "subject": "Collapsed pilgrim at ramp 3", "body": "Motionless for 40 s.",
         "attachments": [str(snapshot)]},
    )  # fmt: skip
    assert result.ok, result.error
    assert result.output["delivered_via"] == "smtp"
    assert result.output["recipients"] == ["medic@team.example"]
    assert result.output["attachments"] == ["snapshot-annotated.png"]
    assert result.output["eml_path"] is None
    (envelope,) = smtp_server.inbox.envelopes
    assert envelope.mail_from == "uav@ops.example"
    assert envelope.rcpt_tos == ["medic@team.example"]
    assert isinstance(envelope.original_content, bytes)
    message = parse(envelope.original_content)
    assert message["Subject"] == "Collapsed pilgrim at ramp 3"
    assert message["Message-ID"] == result.output["message_id"]
    body = message.get_body(("plain",))
    assert body is not None and "Motionless for 40 s." in body.get_content()
    assert attachments(message) == {"snapshot-annotated.png": PNG}
    assert not list(config.outbox_dir.glob("*")) if config.outbox_dir.exists() else True


def test_starttls_and_login(config: BuiltinConfig, tls_smtp_server: MailServer, snapshot: Path) -> None:
    settings = smtp_config(
        config,
        tls_smtp_server,
        smtp_starttls=True,
        smtp_ca_file=tls_smtp_server.ca_file,
        smtp_username=SMTP_USER,
        smtp_password=SMTP_PASSWORD,
    )
    receipt = send_email(settings, ["ops@team.example"], "Über Wind", "Gusts 14 m/s: landing.", [snapshot])
    assert receipt.delivered_via == "smtp"
    assert tls_smtp_server.inbox.logins == [SMTP_USER]
    (envelope,) = tls_smtp_server.inbox.envelopes
    assert isinstance(envelope.original_content, bytes)
    message = parse(envelope.original_content)
    assert message["Subject"] == "Über Wind"
    assert attachments(message) == {"snapshot-annotated.png": PNG}


def test_untrusted_certificate_is_an_error_not_retried(
    config: BuiltinConfig, tls_smtp_server: MailServer, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    tools = harness(smtp_config(config, tls_smtp_server, smtp_starttls=True))  # the system CAs do not know it
    result = tools.call("alerts.send_email", {"to": ["ops@team.example"], "subject": "s", "body": "b"})
    assert result.status == "error" and result.attempts == 1
    assert "certificate" in (result.error or "")
    assert not tls_smtp_server.inbox.envelopes


def test_wrong_password_is_an_error_and_the_password_is_not_shown(
    config: BuiltinConfig, tls_smtp_server: MailServer, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    settings = smtp_config(
        config, tls_smtp_server, smtp_starttls=True, smtp_ca_file=tls_smtp_server.ca_file,
        smtp_username=SMTP_USER, smtp_password="hunter2-wrong",
    )  # fmt: skip
    result = harness(settings).call("alerts.send_email", {"to": ["ops@team.example"], "subject": "s", "body": "b"})
    assert result.status == "error" and result.attempts == 1
    assert "refused the login" in (result.error or "")
    assert "hunter2" not in (result.error or "")
    assert "hunter2" not in repr(settings) and "hunter2" not in settings.model_dump_json()


def test_outbox_when_no_smtp_host(
    config: BuiltinConfig, snapshot: Path, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    result = harness(config).call(
        "alerts.send_email",
        {"to": ["medic@team.example", "Ops <ops@team.example>"], "subject": "Lost child", "body": "Near gate 7.",
         "attachments": [str(snapshot)]},
    )  # fmt: skip
    assert result.ok, result.error
    assert result.output["delivered_via"] == "outbox"
    path = Path(result.output["eml_path"])
    assert path.parent == config.outbox_dir and path.suffix == ".eml"
    assert list(config.outbox_dir.iterdir()) == [path]  # no temporary file left behind
    message = parse(path.read_bytes())
    assert message["To"] == "medic@team.example, Ops <ops@team.example>"
    assert message["Subject"] == "Lost child"
    assert message["Message-ID"] == result.output["message_id"]
    assert attachments(message) == {"snapshot-annotated.png": PNG}
    assert result.output["recipients"] == ["medic@team.example", "ops@team.example"]


def test_missing_attachment_is_named_and_nothing_is_sent(
    config: BuiltinConfig, smtp_server: MailServer, snapshot: Path, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    for settings in (config, smtp_config(config, smtp_server)):
        result = harness(settings).call(
            "alerts.send_email",
            {"to": ["a@b.example"], "subject": "s", "body": "b", "attachments": [str(snapshot), "/no/such/photo.png"]},
        )
        assert result.status == "error" and result.attempts == 1
        assert "/no/such/photo.png" in (result.error or "")
    assert not smtp_server.inbox.envelopes
    assert not config.outbox_dir.exists() or not list(config.outbox_dir.iterdir())


def test_rejected_recipient_is_an_error_with_the_server_reply(
    config: BuiltinConfig, smtp_server: MailServer, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    smtp_server.inbox.reject.add("ghost@team.example")
    tools = harness(smtp_config(config, smtp_server))
    result = tools.call("alerts.send_email", {"to": ["ghost@team.example"], "subject": "s", "body": "b"})
    assert result.status == "error" and result.attempts == 1
    assert "550" in (result.error or "") and "mailbox unavailable" in (result.error or "")
    # one good address among refused ones: sent, and the receipt says who was refused
    result = tools.call(
        "alerts.send_email", {"to": ["ghost@team.example", "medic@team.example"], "subject": "s", "body": "b"}
    )
    assert result.ok, result.error
    assert result.output["recipients"] == ["medic@team.example"]
    assert result.output["refused"] == ["ghost@team.example (550)"]
    assert [e.rcpt_tos for e in smtp_server.inbox.envelopes] == [["medic@team.example"]]


def test_rejected_message_5xx_is_not_retried_but_4xx_is(
    config: BuiltinConfig, smtp_server: MailServer, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    tools = harness(smtp_config(config, smtp_server))
    smtp_server.inbox.data_reply = "554 5.7.1 Message rejected as spam"
    result = tools.call("alerts.send_email", {"to": ["a@b.example"], "subject": "s", "body": "b"})
    assert result.status == "error" and result.attempts == 1
    assert "554 5.7.1 Message rejected as spam" in (result.error or "")
    (kept,) = config.outbox_dir.glob("*.eml")  # refused for good: a copy for the operator
    assert str(kept) in (result.error or "") and parse(kept.read_bytes())["Subject"] == "s"
    smtp_server.inbox.data_reply = "451 4.3.0 Try again later"
    result = tools.call("alerts.send_email", {"to": ["a@b.example"], "subject": "s2", "body": "b"})
    assert result.status == "error" and result.attempts == 3  # the server kept nothing: safe to resend
    assert "451" in (result.error or "")
    assert len(tools.delays) == 2


def test_connection_refused_is_retried(config: BuiltinConfig, harness: Callable[[BuiltinConfig], Harness]) -> None:
    changes = {"smtp_host": "127.0.0.1", "smtp_port": free_port(), "smtp_starttls": False}
    settings = BuiltinConfig.model_validate({**config.model_dump(), **changes})
    tools = harness(settings)
    result = tools.call("alerts.send_email", {"to": ["a@b.example"], "subject": "s", "body": "b"})
    assert result.status == "error" and result.attempts == 3
    assert "cannot reach the mail server" in (result.error or "")
    assert len(tools.delays) == 2


def test_bad_address_is_refused(config: BuiltinConfig, harness: Callable[[BuiltinConfig], Harness]) -> None:
    result = harness(config).call("alerts.send_email", {"to": ["not an address"], "subject": "s", "body": "b"})
    assert result.status == "error" and "not an e-mail address" in (result.error or "")
    result = harness(config).call("alerts.send_email", {"to": [], "subject": "s", "body": "b"})
    assert result.status == "error" and (result.error or "").startswith("invalid arguments")
