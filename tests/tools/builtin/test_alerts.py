"""alerts.webhook against a local HTTP server and the outbox, and alerts.notify routing on each channel."""

from __future__ import annotations

import email
import email.policy
import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import yaml

from tools.builtin import BuiltinConfig

from .conftest import ROOT, Harness, MailServer
from .local_http import LocalHTTPServer, Reply, free_port, json_reply, text_reply

MISSION = Path(__file__).parents[3] / "missions" / "hajj_emergency.yaml"


def settings(config: BuiltinConfig, **changes: object) -> BuiltinConfig:
    return BuiltinConfig.model_validate({**config.model_dump(), **changes})


def test_webhook_posts_json_and_reports_the_status(
    config: BuiltinConfig, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    payload = {"event": "collapse", "lat": 21.4225, "lon": 39.8733, "tags": ["medical"]}
    with LocalHTTPServer([text_reply("queued", status=202)]) as server:
        result = harness(config).call("alerts.webhook", {"payload": payload, "url": server.url + "/hooks/T0KEN123"})
    assert result.ok, result.error
    (request,) = server.requests
    assert request.method == "POST" and request.path == "/hooks/T0KEN123"
    assert request.headers["content-type"] == "application/json" and request.json() == payload
    output = result.output
    assert output["delivered_via"] == "webhook" and output["status"] == 202
    assert output["endpoint"] == server.url and "T0KEN123" not in json.dumps(output)  # the path may be a secret
    excerpt = output["response_excerpt"].splitlines()
    assert excerpt[1] == "queued" and excerpt[0].startswith("<<<untrusted") and excerpt[-1] == "<<<end>>>"
    assert result.untrusted  # the endpoint's answer is outside text


def test_webhook_uses_the_configured_url(config: BuiltinConfig, harness: Callable[[BuiltinConfig], Harness]) -> None:
    with LocalHTTPServer([json_reply({"ok": True})]) as server:
        result = harness(settings(config, webhook_url=server.url + "/alerts")).call(
            "alerts.webhook", {"payload": {"a": 1}}
        )
    assert result.ok and result.output["status"] == 200
    assert [r.path for r in server.requests] == ["/alerts"]


def test_webhook_without_url_goes_to_the_outbox(
    config: BuiltinConfig, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    result = harness(config).call("alerts.webhook", {"payload": {"event": "fire", "level": 3}})
    assert result.ok, result.error
    assert result.output["delivered_via"] == "outbox" and result.output["status"] is None
    saved = json.loads(Path(result.output["path"]).read_text())
    assert saved["payload"] == {"event": "fire", "level": 3} and saved["url"] is None and saved["time"]


def test_webhook_retries_only_when_nothing_can_have_been_processed(
    config: BuiltinConfig, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    tools = harness(config)
    with LocalHTTPServer([Reply(503), Reply(503), Reply(204)]) as busy:
        result = tools.call("alerts.webhook", {"payload": {"n": 1}, "url": busy.url})
    assert result.ok and result.attempts == 3 and result.output["status"] == 204
    with LocalHTTPServer([text_reply("boom", status=500)]) as broken:
        result = tools.call("alerts.webhook", {"payload": {"n": 2}, "url": broken.url})
    assert result.status == "error" and result.attempts == 1 and len(broken.requests) == 1  # may have acted
    assert "HTTP 500" in (result.error or "") and "boom" in (result.error or "")
    with LocalHTTPServer([text_reply("no such hook", status=404)]) as missing:
        result = tools.call("alerts.webhook", {"payload": {"n": 3}, "url": missing.url})
    assert result.status == "error" and result.attempts == 1 and "404" in (result.error or "")
    result = tools.call("alerts.webhook", {"payload": {"n": 4}, "url": f"http://127.0.0.1:{free_port()}/x"})
    assert result.status == "error" and result.attempts == 3 and "nothing was sent" in (result.error or "")
    result = tools.call("alerts.webhook", {"payload": {"n": 5}, "url": "file:///etc/passwd"})
    assert result.status == "error" and result.attempts == 1 and "http(s)" in (result.error or "")


def test_webhook_that_times_out_after_the_post_is_not_sent_again(
    config: BuiltinConfig, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    def slow(_request: object) -> Reply:
        time.sleep(1.0)
        return Reply(200)

    with LocalHTTPServer(slow) as server:
        result = harness(settings(config, http_timeout_s=0.2)).call(
            "alerts.webhook", {"payload": {"n": 1}, "url": server.url}
        )
    assert result.status == "error" and result.attempts == 1
    assert "may have arrived" in (result.error or "")
    assert len(server.requests) == 1


def test_notify_email_to_the_outbox_lists_unavailable_artefacts(
    config: BuiltinConfig, tmp_path: Path, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    position = tmp_path / "position.json"
    position.write_text('{"lat": 21.4225, "lon": 39.8733}')
    result = harness(config).call(
        "alerts.notify",
        {"subject": "Collapsed pilgrim", "body": "Motionless 40 s.", "to": "medic@team.example, lead@team.example",
         "attach": [str(position), "snapshot", "world_model"]},
    )  # fmt: skip
    assert result.ok, result.error
    output = result.output
    assert output["channel"] == "email" and output["delivered_via"] == "outbox"
    assert output["recipients"] == ["medic@team.example", "lead@team.example"]
    assert output["attached"] == [str(position)] and output["unavailable"] == ["snapshot", "world_model"]
    message = email.message_from_bytes(Path(output["path"]).read_bytes(), policy=email.policy.default)
    assert isinstance(message, email.message.EmailMessage)
    body = message.get_body(("plain",))
    assert body is not None and "Not available: snapshot, world_model" in body.get_content()
    assert [part.get_filename() for part in message.iter_attachments()] == ["position.json"]


def test_notify_email_over_smtp_to_the_configured_recipients(
    config: BuiltinConfig, smtp_server: MailServer, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    tools = harness(
        settings(
            config, smtp_host=smtp_server.host, smtp_port=smtp_server.port, smtp_starttls=False,
            alert_recipients=["ops@team.example", "medic@team.example"],
        )
    )  # fmt: skip
    result = tools.call("alerts.notify", {"subject": "Wind over limit", "body": "Landing."})
    assert result.ok, result.error
    assert result.output["delivered_via"] == "smtp" and result.output["path"] is None
    (envelope,) = smtp_server.inbox.envelopes
    assert envelope.rcpt_tos == ["ops@team.example", "medic@team.example"]


def test_notify_webhook_and_log_channels(config: BuiltinConfig, harness: Callable[[BuiltinConfig], Harness]) -> None:
    with LocalHTTPServer([Reply(200)]) as server:
        tools = harness(settings(config, webhook_url=server.url))
        hook = tools.call(
            "alerts.notify", {"subject": "Fire", "body": "Tent 12", "channel": "webhook", "attach": ["snapshot"]}
        )
    assert hook.ok and hook.output["delivered_via"] == "webhook" and hook.output["status"] == 200
    sent = server.requests[0].json()
    assert (sent["subject"], sent["body"], sent["unavailable"]) == ("Fire", "Tent 12", ["snapshot"])
    assert sent["reported_by"] == ROOT.id
    first = tools.call("alerts.notify", {"subject": "One", "body": "first", "channel": "log"})
    second = tools.call("alerts.notify", {"subject": "Two", "body": "second", "channel": "log", "to": ["a@b.example"]})
    assert first.ok and second.ok and first.output["path"] == second.output["path"]
    lines = [json.loads(line) for line in Path(first.output["path"]).read_text().splitlines()]
    assert [(r["subject"], r["to"], r["reported_by"]) for r in lines] == [
        ("One", [], "tester"),
        ("Two", ["a@b.example"], "tester"),
    ]
    assert Path(first.output["path"]) == config.outbox_dir / "notifications.jsonl"


def test_notify_accepts_what_the_mission_dsl_sends(
    config: BuiltinConfig, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    """The ``action: notify`` step of the emergency mission, its templates filled in, fits the tool's schema."""
    mission = yaml.safe_load(MISSION.read_text())
    steps = [s for s in _steps(mission) if s.get("action") == "notify"]
    assert steps, "the mission has a notify step"
    args = dict(steps[0]["args"])
    args.update(to="medic@team.example", subject="Collapsed pilgrim at 21.42, 39.87", body="Motionless for 40 s.")
    result = harness(config).call("alerts.notify", args)
    assert result.ok, result.error
    assert result.output["unavailable"] == ["position", "snapshot", "world_model", "assessment"]


def _steps(node: object) -> list[dict[str, Any]]:
    found: list[dict[str, Any]] = []
    if isinstance(node, dict):
        if "action" in node:
            found.append(node)
        for value in node.values():
            found += _steps(value)
    elif isinstance(node, list):
        for item in node:
            found += _steps(item)
    return found


def test_files_outside_the_attachment_folders_are_never_sent(
    config: BuiltinConfig, tmp_path: Path, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    secret = tmp_path / "keys" / "id_ed25519"
    secret.parent.mkdir()
    secret.write_text("-----BEGIN OPENSSH PRIVATE KEY-----")
    allowed = tmp_path / "run"
    allowed.mkdir()
    (allowed / "snapshot.png").write_bytes(b"\x89PNG")
    tools = harness(config.model_copy(update={"attachment_dirs": [allowed]}))
    mail = tools.call("alerts.send_email", {"to": ["ops@team.example"], "subject": "s", "body": "b",
                                            "attachments": [str(secret)]})  # fmt: skip
    assert mail.status == "error" and "outside the folders alerts may attach from" in (mail.error or "")
    assert not list((tmp_path / "outbox").glob("*.eml"))  # nothing written, nothing sent
    notified = tools.call("alerts.notify", {"subject": "s", "body": "b", "channel": "email",
                                             "attach": [str(allowed / "snapshot.png"), str(secret)]})  # fmt: skip
    assert notified.ok, notified.error
    assert notified.output["attached"] == [str(allowed / "snapshot.png")]
    assert notified.output["unavailable"] == [str(secret)]


def test_an_email_is_kept_in_the_outbox_when_the_mail_server_is_down(
    config: BuiltinConfig, tmp_path: Path, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    down = config.model_copy(update={"smtp_host": "127.0.0.1", "smtp_port": free_port(), "http_timeout_s": 0.5})
    tools = harness(down)
    result = tools.call("alerts.send_email", {"to": ["ops@team.example"], "subject": "Casualty", "body": "Mina"})
    assert (result.status, result.attempts) == ("error", 3)  # retried: nothing can have been sent
    kept = list((tmp_path / "outbox").glob("undelivered-*.eml"))
    assert [p.name for p in kept] == [f"undelivered-{result.call_id}.eml"]  # one copy for the three attempts
    assert str(kept[0]) in (result.error or "")
    message = email.message_from_bytes(kept[0].read_bytes(), policy=email.policy.default)
    assert message["Subject"] == "Casualty"
    no_one = tools.call("alerts.notify", {"subject": "Casualty", "body": "Mina", "channel": "email"})
    assert no_one.status == "error" and "no recipients" in (no_one.error or "") and "a copy was kept" in no_one.error


def test_a_webhook_payload_is_kept_in_the_outbox_when_the_post_fails(
    config: BuiltinConfig, tmp_path: Path, harness: Callable[[BuiltinConfig], Harness]
) -> None:
    tools = harness(config)
    url = f"http://127.0.0.1:{free_port()}/hook?token=s3cr3t"
    result = tools.call("alerts.webhook", {"payload": {"event": "collapse"}, "url": url})
    assert result.status == "error"
    (kept,) = (tmp_path / "outbox").glob("undelivered-*.json")
    record = json.loads(kept.read_text())
    assert record["payload"] == {"event": "collapse"} and "s3cr3t" not in kept.read_text()
