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
import hashlib
import re
import smtplib
import ssl
import sys
from collections.abc import Sequence
from datetime import UTC, datetime
from email.headerregistry import BaseHeader, HeaderRegistry
from email.message import EmailMessage
from email.utils import format_datetime, make_msgid, parseaddr
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, Field

from ..errors import ToolError, TransientToolError
from .allowlist import check_recipients_allowed
from .config import BuiltinConfig, may_attach
from .eml import PLAIN_NAME, PLAIN_TYPE, attachment_type, base64_lines, new_boundary, plain_message
from .outbox import discard_undelivered, keep_undelivered, write_file

MAX_ATTACHMENTS_BYTES = 25 * 1024 * 1024
_NEWLINES = re.compile(r"\r\n|\r|\n")


class _HeaderClasses(HeaderRegistry):
    """The standard header registry, but each header's class made once: the standard one makes a new class every
    time a header is set or read (a dozen per alert, the costliest part of building it)."""

    def __init__(self) -> None:
        super().__init__()
        self._made: dict[str, type[BaseHeader]] = {}

    def __getitem__(self, name: str) -> type[BaseHeader]:
        key = name.lower()
        made = self._made.get(key)
        if made is None:
            made = self._made[key] = super().__getitem__(name)
        return made


MESSAGE_POLICY = email.policy.SMTP.clone(header_factory=_HeaderClasses())
"""The policy of the messages :func:`build_message` makes: ``email.policy.SMTP`` (CRLF, 78 columns, 8-bit), its
header classes made once."""


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
    check_size(files)
    return files


def check_size(files: Sequence[Path]) -> None:
    """A :class:`ToolError` when the files total more than :data:`MAX_ATTACHMENTS_BYTES`."""
    size = sum(p.stat().st_size for p in files)
    if size > MAX_ATTACHMENTS_BYTES:
        raise ToolError(f"attachments total {size / 1e6:.1f} MB, over the {MAX_ATTACHMENTS_BYTES / 1e6:.0f} MB limit")


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
    config: BuiltinConfig,
    to: Sequence[str],
    subject: str,
    body: str,
    files: Sequence[Path],
    *,
    date: str | None = None,
    message_id: str | None = None,
) -> EmailMessage:
    """The message: From, To (when any), Subject (on one line), Date, Message-ID (made now unless given), a text
    body, the files.

    Each file is attached exactly as ``add_attachment`` attaches bytes (base64, its name as the filename), only
    quicker (:func:`attach_bytes`): this is on the way from the frame that confirms a casualty to the alert."""
    message = EmailMessage(policy=MESSAGE_POLICY)
    message["From"] = config.smtp_from
    if to:
        message["To"] = ", ".join(to)
    message["Subject"] = " ".join(subject.split())
    message["Date"] = date or format_datetime(datetime.now(UTC))
    message["Message-ID"] = message_id or _new_message_id(config)
    message.set_content(body)
    for file in files:
        attach_bytes(message, file.read_bytes(), *attachment_type(file.name), file.name)
    return message


def attach_bytes(message: EmailMessage, data: bytes, maintype: str, subtype: str, filename: str) -> None:
    """``message.add_attachment(data, maintype=maintype, subtype=subtype, filename=filename)``, the same part, in a
    fraction of the time.

    The content manager encodes base64 in 57-byte chunks (thousands of calls for a picture) and parses every
    header it sets; here the data is encoded in one call, and when the header lines are plain (a type and a file
    name of letters, digits, ``.``, ``-``, ``_``, on one line) they are stored as the text the header classes
    would fold them to, which :func:`message_bytes` and ``as_bytes`` write as they are. Any other name or type
    takes ``add_attachment``'s own headers.
    """
    policy = message.policy
    disposition = f'attachment; filename="{filename}"'
    plain = (
        isinstance(policy, email.policy.EmailPolicy)
        and policy.refold_source != "all"
        and bool(PLAIN_TYPE.match(maintype) and PLAIN_TYPE.match(subtype) and PLAIN_NAME.match(filename))
        and len("Content-Disposition: ") + len(disposition) <= (policy.max_line_length or sys.maxsize)
    )
    if plain:
        if message.get_content_maintype() != "multipart" or message.get_content_subtype() != "mixed":
            message.make_mixed()
        part = EmailMessage(policy=policy)
        part.set_raw("Content-Type", f"{maintype}/{subtype}")
        part.set_raw("Content-Transfer-Encoding", "base64")
        part.set_raw("Content-Disposition", disposition)
        part.set_raw("MIME-Version", "1.0")
        message.attach(part)
    else:
        message.add_attachment(b"", maintype=maintype, subtype=subtype, filename=filename)  # its headers
        attachments = message.get_payload()
        assert isinstance(attachments, list) and isinstance(attachments[-1], EmailMessage)
        part = attachments[-1]
    part.set_payload(base64_lines(data, policy.max_line_length))


def message_bytes(message: EmailMessage, policy: email.policy.Policy | None = None) -> bytes:
    """``message.as_bytes(policy=policy)``: the same bytes, several times faster for the messages
    :func:`build_message` makes.

    The standard generator writes a body line by line (thousands of writes for a picture in base64) and looks for
    its boundary with a regular expression over the whole text; here each body is one substitution and one encode,
    the headers are folded by the policy exactly as the generator folds them, and a new boundary (same form as the
    generator's, stored in the message as it does) is checked with a substring search. Anything else (nested or
    signed multiparts, ``message/*`` parts, a preamble or epilogue, a 7-bit policy, another policy than the
    message's) goes to the standard generator.
    """
    own = message.policy
    if policy is email.policy.SMTP and own is MESSAGE_POLICY:
        policy = own  # the same settings (only its header classes are made once), so the same bytes
    if (policy is not None and policy is not own) or not isinstance(own, email.policy.EmailPolicy):
        return message.as_bytes(policy=policy)
    subparts = message.get_payload() if message.is_multipart() else None
    parts = [p for p in subparts if isinstance(p, EmailMessage)] if isinstance(subparts, list) else []
    simple = own.cte_type != "7bit" and (
        _is_leaf(message)
        if subparts is None
        else (
            len(parts) == len(subparts)
            and message.get_content_type() == "multipart/mixed"
            and message.preamble is None
            and message.epilogue is None
            and all(_is_leaf(p) for p in parts)
        )
    )
    if not simple:
        return message.as_bytes(policy=policy)
    newline = own.linesep
    if subparts is None:
        return _header_block(message, own) + _body(message, newline)
    texts = [_header_block(part, own) + _body(part, newline) for part in parts]
    boundary = message.get_boundary()
    if not boundary:
        boundary = new_boundary(newline.encode("ascii").join(texts))
        message.set_boundary(boundary)
    delimiter = f"{newline}--{boundary}{newline}".encode("ascii")
    body = b"".join(
        (f"--{boundary}{newline}".encode("ascii"), delimiter.join(texts), f"{newline}--{boundary}--{newline}".encode())
    )
    return _header_block(message, own) + body


def _is_leaf(part: EmailMessage) -> bool:
    """A part the generator writes as its payload, line endings made the policy's: not a multipart, not a
    ``message/*``, its payload text (or nothing)."""
    payload = part._payload  # type: ignore[attr-defined]
    return not part.is_multipart() and part.get_content_maintype() != "message" and isinstance(payload, str | None)


def _header_block(part: EmailMessage, policy: email.policy.Policy) -> bytes:
    """The headers as the bytes generator writes them: each folded by the policy, then an empty line."""
    return b"".join(policy.fold_binary(name, value) for name, value in part.raw_items()) + policy.linesep.encode()


def _body(part: EmailMessage, newline: str) -> bytes:
    """The payload with every line ending the policy's (8-bit text is held as surrogate escapes, as the
    generator's ``write`` expects)."""
    payload: str | None = part._payload  # type: ignore[attr-defined]  # as stored: get_payload() decodes 8-bit text
    if not payload:
        return b""
    lines = payload.replace("\n", newline) if "\r" not in payload else _NEWLINES.sub(newline, payload)  # same, faster
    return lines.encode("ascii", "surrogateescape")


def send_email(
    config: BuiltinConfig,
    to: Sequence[str],
    subject: str,
    body: str,
    attachments: Sequence[str | Path] = (),
    keep_as: str | None = None,
    message_id: str | None = None,
) -> EmailReceipt:
    """Send over SMTP when ``config.smtp_host`` is set, else write an ``.eml`` to the outbox. With no recipients
    the message still goes to the outbox (someone may forward it), but SMTP refuses. When sending fails in any way
    (server down, refused, no recipients), a copy goes to the outbox too and the error says where; ``keep_as`` (the
    call id) names that copy, so the retries of one call keep one copy, removed once a retry delivers.
    ``message_id`` (see :func:`keyed_message_id`) replaces a new random Message-ID."""
    return _send(config, to, subject, body, check_attachments(config, attachments), keep_as, message_id)


def send_files(
    config: BuiltinConfig,
    to: Sequence[str],
    subject: str,
    body: str,
    files: Sequence[Path],
    keep_as: str | None = None,
    message_id: str | None = None,
) -> EmailReceipt:
    """:func:`send_email` for files the caller has already found inside the attachment folders (``alerts.notify``
    sorts what it is given into files and names that are not): only their total size is checked again, so the
    paths are not resolved twice on the way to an alert."""
    check_size(files)
    return _send(config, to, subject, body, files, keep_as, message_id)


def encode_message(
    config: BuiltinConfig,
    to: Sequence[str],
    subject: str,
    body: str,
    files: Sequence[Path],
    message_id: str | None = None,
) -> tuple[bytes, str]:
    """The message's bytes and its Message-ID (``message_id``, else a new one): written straight
    (:func:`.eml.plain_message`) when everything in it is plain, else :func:`build_message` and
    :func:`message_bytes`; the same bytes either way."""
    message_id = message_id or _new_message_id(config)
    date = format_datetime(datetime.now(UTC))
    attachments = [(file.name, file.read_bytes()) for file in files]
    data = plain_message(config.smtp_from, to, subject, body, attachments, date=date, message_id=message_id)
    if data is not None:
        return data, message_id
    message = build_message(config, to, subject, body, files, date=date, message_id=message_id)
    return message_bytes(message), str(message["Message-ID"])


def _domain(config: BuiltinConfig) -> str:
    return parseaddr(config.smtp_from)[1].rpartition("@")[2] or "localhost"


def _new_message_id(config: BuiltinConfig) -> str:
    """A new Message-ID in the sender's domain (``localhost`` when the sender has none)."""
    return make_msgid(domain=_domain(config))


def keyed_message_id(config: BuiltinConfig, tool: str, idempotency_key: str) -> str:
    """The Message-ID of the mail a tool sends for an idempotency key: the same for every re-run of the action, so
    a mail server or client that drops repeated Message-IDs sees one message.

    >>> config = BuiltinConfig(smtp_from="UAV <uav@ops.example>")
    >>> first = keyed_message_id(config, "alerts.notify", "run-1:alert:0")
    >>> first == keyed_message_id(config, "alerts.notify", "run-1:alert:0"), first.endswith("@ops.example>")
    (True, True)
    """
    digest = hashlib.sha256(f"{tool}\n{idempotency_key}".encode()).hexdigest()[:40]
    return f"<{digest}.idem@{_domain(config)}>"


def _send(
    config: BuiltinConfig,
    to: Sequence[str],
    subject: str,
    body: str,
    files: Sequence[Path],
    keep_as: str | None,
    message_id: str | None = None,
) -> EmailReceipt:
    recipients = check_recipients(to)
    check_recipients_allowed(config, recipients)  # before anything is kept: a refused message is not an alert
    data, message_id = encode_message(config, to, subject, body, files, message_id)
    names = [f.name for f in files]
    if not config.smtp_host:
        path = write_file(config.outbox_dir, ".eml", data)
        return EmailReceipt(
            delivered_via="outbox", message_id=message_id, recipients=recipients, attachments=names, eml_path=str(path)
        )
    try:
        if not recipients:
            raise ToolError("no recipients: pass 'to', or set AGENTIC_UAV_ALERT_RECIPIENTS")
        accepted, refused = smtp_send(config, config.smtp_host, data, recipients)
    except Exception as exc:  # keep the message for the operator, whatever went wrong: no alert is lost
        path = keep_undelivered(config.outbox_dir, keep_as, ".eml", data)
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


def smtp_send(config: BuiltinConfig, host: str, data: bytes, recipients: Sequence[str]) -> tuple[list[str], list[str]]:
    """Send the message ``data`` (CRLF line ends) to ``recipients``; returns the accepted and the refused
    (``"addr (550)"``) addresses."""
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
            code, reply = smtp.data(data)
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


__all__ = [
    "EmailReceipt",
    "attach_bytes",
    "base64_lines",
    "build_message",
    "check_attachments",
    "check_recipients",
    "check_size",
    "encode_message",
    "keyed_message_id",
    "message_bytes",
    "send_email",
    "send_files",
    "smtp_send",
]
