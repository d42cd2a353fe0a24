"""The alert e-mail written straight to bytes when everything in it is plain: the very bytes
:func:`~tools.builtin.mail.build_message` and :func:`~tools.builtin.mail.message_bytes` give (tested byte for
byte), without the standard library's header classes, which parse every header set or read and took most of the
time of an alert. Plain means ASCII headers on one line each with bare addresses (``ops@x.org``, ``Ops Team
<ops@x.org>``), a 7-bit text body with lines of at most 78 characters, and attachments whose names and types need
no quoting; anything else is built by the standard library (:func:`plain_message` returns ``None``).

>>> data = plain_message("uav@x.org", ["ops@x.org"], "Collapse", "Help.", [],
...     date="Sun, 22 Nov 2026 06:05:30 +0000", message_id="<1.2@x.org>")
>>> data.split(b"\\r\\n")[:3]
[b'From: uav@x.org', b'To: ops@x.org', b'Subject: Collapse']
"""

from __future__ import annotations

import binascii
import mimetypes
import random
import re
import sys
from collections.abc import Sequence

MAX_LINE = 78
"""The line length of the messages (``email.policy.SMTP``'s ``max_line_length``)."""
PLAIN_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9._-]*\Z")
PLAIN_TYPE = re.compile(r"[a-z0-9][a-z0-9.+-]*\Z")
_ADDRESS = r"[A-Za-z0-9_%+-]+(?:\.[A-Za-z0-9_%+-]+)*@[A-Za-z0-9-]+(?:\.[A-Za-z0-9-]+)*"  # dot-atoms only
_PLAIN_ADDRESS = re.compile(rf"(?:[A-Za-z0-9]+(?: [A-Za-z0-9]+)* <{_ADDRESS}>|{_ADDRESS})\Z")
_PLAIN_ID = re.compile(rf"<{_ADDRESS}>\Z")
_BOUNDARY_DIGITS = len(repr(sys.maxsize - 1))
CRLF = b"\r\n"


def attachment_type(filename: str) -> tuple[str, str]:
    """The MIME type an attachment is sent as, from its name: compressed files (``.gz``) as plain bytes."""
    kind, encoding = mimetypes.guess_type(filename)
    if encoding is not None:  # a .gz file is gzip data, not text
        return "application", "octet-stream"
    maintype, subtype = (kind or "application/octet-stream").split("/", 1)
    return maintype, subtype


def base64_lines(data: bytes, max_line_length: int | None) -> str:
    """``data`` in base64 as the e-mail content manager writes an attachment: lines of ``max_line_length // 4 * 4``
    characters (76 for 78), each ending in a newline; nothing for nothing."""
    if not data:
        return ""
    width = (max_line_length or 78) // 4 * 4
    encoded = binascii.b2a_base64(data, newline=False)
    return (b"\n".join([encoded[i : i + width] for i in range(0, len(encoded), width)]) + b"\n").decode("ascii")


def new_boundary(text: bytes) -> str:
    """A boundary of the generator's form (``=`` * 15, a random number, ``==``) that occurs nowhere in ``text``."""
    boundary = "=" * 15 + str(random.randrange(sys.maxsize)).zfill(_BOUNDARY_DIGITS) + "=="
    candidate, counter = boundary, 0
    while f"--{candidate}".encode("ascii") in text:
        candidate, counter = f"{boundary}.{counter}", counter + 1
    return candidate


def plain_message(
    sender: str,
    to: Sequence[str],
    subject: str,
    body: str,
    attachments: Sequence[tuple[str, bytes]],
    *,
    date: str,
    message_id: str,
) -> bytes | None:
    """The message's bytes (CRLF line ends), laid out as ``build_message`` lays it out: From, To (when any),
    Subject, Date, Message-ID, then the text and each ``(file name, data)`` attachment; ``None`` when anything in it
    is not plain (see the module's notes)."""
    headers = [("From", sender), *([("To", ", ".join(to))] if to else []), ("Subject", " ".join(subject.split()))]
    headers += [("Date", date), ("Message-ID", message_id)]
    plain = (
        bool(_PLAIN_ADDRESS.match(sender) and _PLAIN_ID.match(message_id))
        and all(_PLAIN_ADDRESS.match(address) for address in to)
        and all(value.isascii() and value.isprintable() and "=?" not in value for _, value in headers)
        and all(len(name) + 2 + len(value) <= MAX_LINE for name, value in headers)
        and body.isascii()
        and headers[-3][1] != ""  # an empty Subject is written without its space
    )
    lines = body.encode("ascii", "replace").splitlines()  # as the content manager splits a text
    if not plain or any(len(line) > MAX_LINE for line in lines):
        return None
    top = b"".join(f"{name}: {value}".encode("ascii") + CRLF for name, value in headers)
    text = b'Content-Type: text/plain; charset="utf-8"\r\nContent-Transfer-Encoding: 7bit\r\n'
    text_body = CRLF.join(lines) + CRLF
    if not attachments:
        return top + text + b"MIME-Version: 1.0\r\n" + CRLF + text_body
    parts = [text + CRLF + text_body]
    for name, data in attachments:
        maintype, subtype = attachment_type(name)
        disposition = f'Content-Disposition: attachment; filename="{name}"'
        if not (PLAIN_NAME.match(name) and PLAIN_TYPE.match(maintype) and PLAIN_TYPE.match(subtype)):
            return None
        if maintype in ("message", "multipart"):  # not a leaf part: the generator writes it its own way
            return None
        if len(disposition) > MAX_LINE:
            return None
        head = f"Content-Type: {maintype}/{subtype}\r\nContent-Transfer-Encoding: base64\r\n{disposition}\r\n"
        encoded = base64_lines(data, MAX_LINE).replace("\n", "\r\n")
        parts.append(head.encode("ascii") + b"MIME-Version: 1.0\r\n" + CRLF + encoded.encode("ascii"))
    boundary = new_boundary(CRLF.join(parts)).encode("ascii")
    kind = b'Content-Type: multipart/mixed; boundary="' + boundary + b'"'
    if len(kind) > MAX_LINE:  # a boundary lengthened to avoid a clash: the header would be folded
        return None
    delimiter = CRLF + b"--" + boundary + CRLF
    opening = top + b"MIME-Version: 1.0\r\n" + kind + CRLF + CRLF
    return opening + b"--" + boundary + CRLF + delimiter.join(parts) + CRLF + b"--" + boundary + b"--" + CRLF


__all__ = ["MAX_LINE", "PLAIN_NAME", "PLAIN_TYPE", "attachment_type", "base64_lines", "new_boundary", "plain_message"]
