"""E-mail for alerts: an RFC 5322 message with attachments, sent over SMTP (STARTTLS, login) or kept in the outbox.

Retries must never send a message twice, so only failures before the server took the message are transient
(:class:`TransientToolError`): no connection, a timeout or a dropped link before ``DATA``, a 4xx reply (the server
said "not now" and kept nothing). A 5xx reply is a :class:`ToolError` with the server's words. A link that breaks
while the server receives the message is a :class:`ToolError` too: it may have been delivered, so it is not resent.

>>> import email, tempfile
>>> config = BuiltinConfig(outbox_dir=Path(tempfile.mkdtemp()))
>>> receipt = send_email(config, ["ops@example.org"], "Wind over limit", "Landing at base.")
>>> receipt.delivered_via, email.message_from_bytes(Path(receipt.eml_path).read_bytes())["Subject"]
('outbox', 'Wind over limit')
"""

from __future__ import annotations

import email.policy
import mimetypes
import smtplib
import ssl
from collections.abc import Sequence
from email.message import EmailMessage
from email.utils import formatdate, make_msgid, parseaddr
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, Field

from ..errors import ToolError, TransientToolError
from .config import BuiltinConfig, may_attach
from .outbox import discard_undelivered, keep_undelivered, write_file

MAX_ATTACHMENTS_BYTES = 25 * 1024 * 1024


class EmailReceipt(BaseModel):
    """What became of an e-mail."""

    delivered_via: Literal["smtp", "outbox"]
    message_id: str
    recipients: list[str] = Field(description="addresses the server accepted (or the message is addressed to)")
    refused: list[str] = Field(default_factory=list, description="addresses the server refused, with its reply code")
    attachments: list[str] = Field(default_factory=list, description="names of the files attached")
    eml_path: str | None = Field(default=None, description="the .eml written to the outbox")


def check_attachments(config: BuiltinConfig, paths: Sequence[str | Path]) -> list[Path]:
    """The attachment files, or a :class:`ToolError` naming every one that is missing, outside the folders alerts
    may attach from (``config.attachment_dirs``), or too big."""
    files = [Path(p).expanduser() for p in paths]
    missing = [str(p) for p in files if not p.is_file()]
    if missing:
        raise ToolError(f"attachment not found: {', '.join(missing)} (nothing was sent)")
    outside = [str(p) for p in files if not may_attach(config, p)]
    if outside:
        folders = ", ".join(str(f) for f in config.attachment_dirs)
        raise ToolError(
            f"attachment outside the folders alerts may attach from ({folders}; AGENTIC_UAV_ATTACHMENT_DIRS): "
            f"{', '.join(outside)} (nothing was sent)"
        )
    size = sum(p.stat().st_size for p in files)
    if size > MAX_ATTACHMENTS_BYTES:
        raise ToolError(f"attachments total {size / 1e6:.1f} MB, over the {MAX_ATTACHMENTS_BYTES / 1e6:.0f} MB limit")
    return files


def check_recipients(to: Sequence[str]) -> list[str]:
    """The bare addresses of ``to`` (``"Ops <ops@x.org>"`` gives ``ops@x.org``), or a :class:`ToolError`."""
    addresses = []
    for entry in to:
        address = parseaddr(entry)[1]
        if "@" not in address or any(c in entry for c in "\r\n") or any(c.isspace() for c in address):
            raise ToolError(f"not an e-mail address: {entry!r}")
        addresses.append(address)
    return addresses


def build_message(
    config: BuiltinConfig, to: Sequence[str], subject: str, body: str, files: Sequence[Path]
) -> EmailMessage:
    """The message: From, To (when any), Subject (on one line), Date, Message-ID, a text body, the files."""
    message = EmailMessage(policy=email.policy.SMTP)
    domain = parseaddr(config.smtp_from)[1].rpartition("@")[2] or "localhost"
    message["From"] = config.smtp_from
    if to:
        message["To"] = ", ".join(to)
    message["Subject"] = " ".join(subject.split())
    message["Date"] = formatdate(usegmt=True)
    message["Message-ID"] = make_msgid(domain=domain)
    message.set_content(body)
    for file in files:
        kind, encoding = mimetypes.guess_type(file.name)
        maintype, subtype = (kind or "application/octet-stream").split("/", 1)
        if encoding is not None:  # a .gz file is gzip data, not text
            maintype, subtype = "application", "octet-stream"
        message.add_attachment(file.read_bytes(), maintype=maintype, subtype=subtype, filename=file.name)
    return message


def send_email(
    config: BuiltinConfig,
    to: Sequence[str],
    subject: str,
    body: str,
    attachments: Sequence[str | Path] = (),
    keep_as: str | None = None,
) -> EmailReceipt:
    """Send over SMTP when ``config.smtp_host`` is set, else write an ``.eml`` to the outbox. With no recipients
    the message still goes to the outbox (someone may forward it), but SMTP refuses. When sending fails in any way
    (server down, refused, no recipients), a copy goes to the outbox too and the error says where; ``keep_as`` (the
    call id) names that copy, so the retries of one call keep one copy, removed once a retry delivers."""
    files = check_attachments(config, attachments)
    recipients = check_recipients(to)
    message = build_message(config, to, subject, body, files)
    message_id = str(message["Message-ID"])
    names = [f.name for f in files]
    if not config.smtp_host:
        path = write_file(config.outbox_dir, ".eml", message.as_bytes())
        return EmailReceipt(
            delivered_via="outbox", message_id=message_id, recipients=recipients, attachments=names, eml_path=str(path)
        )
    try:
        if not recipients:
            raise ToolError("no recipients: pass 'to', or set AGENTIC_UAV_ALERT_RECIPIENTS")
        accepted, refused = smtp_send(config, config.smtp_host, message, recipients)
    except Exception as exc:  # keep the message for the operator, whatever went wrong: no alert is lost
        path = keep_undelivered(config.outbox_dir, keep_as, ".eml", message.as_bytes())
        kept = type(exc) if isinstance(exc, ToolError | TransientToolError) else ToolError
        raise kept(f"{exc} (a copy was kept in {path})") from None
    discard_undelivered(config.outbox_dir, keep_as, ".eml")
    return EmailReceipt(
        delivered_via="smtp", message_id=message_id, recipients=accepted, refused=refused, attachments=names
    )


def _refusal(what: str, code: int, reply: bytes | str) -> Exception:
    text = reply.decode(errors="replace") if isinstance(reply, bytes) else reply
    message = f"the mail server refused {what}: {code} {' '.join(text.split())}"
    return TransientToolError(message) if 400 <= code < 500 else ToolError(message)


def _connect(config: BuiltinConfig, host: str) -> smtplib.SMTP:
    """A connection ready to send: greeted, encrypted and logged in as configured."""
    where = f"{host}:{config.smtp_port}"
    try:
        smtp = smtplib.SMTP(host, config.smtp_port, timeout=config.http_timeout_s)
    except smtplib.SMTPConnectError as exc:
        raise _refusal("the connection", exc.smtp_code, exc.smtp_error) from None
    except OSError as exc:
        raise TransientToolError(f"cannot reach the mail server {where}: {exc}") from None
    try:
        smtp.ehlo()
        if config.smtp_starttls:
            cafile = str(config.smtp_ca_file) if config.smtp_ca_file else None
            smtp.starttls(context=ssl.create_default_context(cafile=cafile))
            smtp.ehlo()
        if config.smtp_username:
            password = config.smtp_password.get_secret_value() if config.smtp_password else ""
            smtp.login(config.smtp_username, password)
        return smtp
    except Exception as exc:
        smtp.close()
        if isinstance(exc, ssl.SSLCertVerificationError):
            raise ToolError(
                f"the certificate of the mail server {where} is not trusted: {exc.verify_message}"
            ) from None
        if isinstance(exc, smtplib.SMTPAuthenticationError):
            raise ToolError(f"the mail server {where} refused the login ({exc.smtp_code})") from None
        if isinstance(exc, smtplib.SMTPNotSupportedError):
            raise ToolError(f"the mail server {where} does not support it: {exc}") from None
        if isinstance(exc, smtplib.SMTPResponseException):
            raise _refusal("the session", exc.smtp_code, exc.smtp_error) from None
        dropped = isinstance(exc, OSError) and not isinstance(exc, smtplib.SMTPException)
        if dropped or isinstance(exc, smtplib.SMTPServerDisconnected):  # nothing was sent yet: safe to try again
            raise TransientToolError(f"the mail server {where} dropped the connection: {exc}") from None
        raise ToolError(f"the mail server {where} cannot be used: {type(exc).__name__}: {exc}") from None


def smtp_send(
    config: BuiltinConfig, host: str, message: EmailMessage, recipients: Sequence[str]
) -> tuple[list[str], list[str]]:
    """Send ``message`` to ``recipients``; returns the accepted and the refused (``"addr (550)"``) addresses."""
    smtp = _connect(config, host)
    try:
        sender = parseaddr(config.smtp_from)[1] or config.smtp_from
        try:
            code, reply = smtp.mail(sender)
            if code != 250:
                raise _refusal(f"the sender {sender}", code, reply)
            refused: dict[str, tuple[int, bytes]] = {}
            for address in recipients:
                code, reply = smtp.rcpt(address)
                if code not in (250, 251):
                    refused[address] = (code, reply)
            if len(refused) == len(recipients):
                worst = max(refused.values(), key=lambda r: r[0])  # a 5xx beats a 4xx: retrying will not help
                raise _refusal(f"every recipient ({', '.join(refused)})", *worst)
        except smtplib.SMTPServerDisconnected as exc:  # nothing was accepted yet: safe to try again
            raise TransientToolError(f"the mail server dropped the connection before the message: {exc}") from None
        except smtplib.SMTPException as exc:
            raise ToolError(f"the mail server cannot take the message: {type(exc).__name__}: {exc}") from None
        except OSError as exc:  # a timeout or a reset before DATA: nothing was accepted yet
            raise TransientToolError(f"the mail server dropped the connection before the message: {exc}") from None
        try:
            code, reply = smtp.data(message.as_bytes(policy=email.policy.SMTP))
        except smtplib.SMTPResponseException as exc:  # DATA itself refused: the message was not sent
            raise _refusal("the message", exc.smtp_code, exc.smtp_error) from None
        except (smtplib.SMTPException, OSError) as exc:
            raise ToolError(
                f"the connection broke while the mail server received the message ({exc}); it may have been "
                "delivered, so it was not sent again"
            ) from None
        if code != 250:
            raise _refusal("the message", code, reply)
    finally:
        try:
            smtp.quit()
        except (smtplib.SMTPException, OSError):
            smtp.close()
    accepted = [a for a in recipients if a not in refused]
    return accepted, [f"{address} ({reply_code})" for address, (reply_code, _) in refused.items()]


__all__ = ["EmailReceipt", "build_message", "check_attachments", "check_recipients", "send_email", "smtp_send"]
