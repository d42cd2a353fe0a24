"""The alert e-mail's quick paths write exactly what the standard library writes: ``attach_bytes`` the part
``add_attachment`` makes, ``base64_lines`` the content manager's base64, ``message_bytes`` the generator's bytes,
and ``plain_message`` a plain alert's whole message; anything not plain is left to the standard library."""

from __future__ import annotations

import base64
import email
import email.policy
import os
import re
from email.message import EmailMessage
from pathlib import Path

import pytest

from tools.builtin import BuiltinConfig
from tools.builtin.eml import plain_message
from tools.builtin.mail import (
    MAX_ATTACHMENTS_BYTES,
    attach_bytes,
    base64_lines,
    build_message,
    encode_message,
    message_bytes,
    send_files,
)
from tools.errors import ToolError

NAMES = [
    "000012.3s-snapshot.png",  # what the runner writes
    "a.png",
    "_x.bin",
    "UPPER.PNG",
    "a b.png",  # quoted by the header classes
    "é.json",  # RFC 2231
    'q"uote.png',
    "-lead.png",
    "a+b.png",
    *("n" * k + ".png" for k in range(28, 38)),  # the line around 78 columns: kept on one line, then folded
]
TYPES = [("image", "png"), ("application", "json"), ("text", "plain"), ("image", "svg+xml"), ("application", "x-gzip")]


def message() -> EmailMessage:
    made = EmailMessage(policy=email.policy.SMTP)
    made["Subject"] = "Collapse"
    made.set_content("Motionless 40 s — at ramp 3.\n")
    return made


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize(("maintype", "subtype"), TYPES)
def test_attach_bytes_makes_the_part_add_attachment_makes(name: str, maintype: str, subtype: str) -> None:
    data = os.urandom(3000)
    standard, quick = message(), message()
    standard.add_attachment(data, maintype=maintype, subtype=subtype, filename=name)
    attach_bytes(quick, data, maintype, subtype, name)
    standard.set_boundary("==b==")
    quick.set_boundary("==b==")
    assert quick.as_bytes() == standard.as_bytes()
    (part,) = quick.iter_attachments()
    assert part.get_filename() == name and part.get_content_type() == f"{maintype}/{subtype}"
    assert part.get_payload(decode=True) == data


@pytest.mark.parametrize("size", [0, 1, 2, 3, 56, 57, 58, 114, 10_000])
def test_base64_lines_are_the_standard_ones(size: int) -> None:
    data = os.urandom(size)
    assert base64_lines(data, 78) == base64.encodebytes(data).decode("ascii")  # 76 characters and a newline a line
    assert base64_lines(data, 40) == "".join(
        base64.b64encode(data[i : i + 30]).decode("ascii") + "\n" for i in range(0, size, 30)
    )


@pytest.fixture
def files(tmp_path: Path) -> list[Path]:
    made = {
        "000042.0s-snapshot.png": b"\x89PNG\r\n\x1a\n" + os.urandom(20_000),
        "000042.0s-world_model.json": ('{\n  "objects": [],\n  "note": "Über"\n}\n' * 200).encode(),
        "empty.txt": b"",
        "a b é.json": b'{"x": 1}\n',
        "trace.gz": b"\x1f\x8b" + bytes(100),
    }
    for name, data in made.items():
        (tmp_path / name).write_bytes(data)
    return [tmp_path / name for name in made]


@pytest.mark.parametrize(
    ("to", "subject", "body"),
    [
        (["Ops <ops@example.org>", "medic@example.org"], "Collapse at 21.4225, 39.8733 — " + "long " * 20, "help é"),
        ([], "plain", "ascii\r\nmixed\rline\nendings"),
        (["medic@example.org"], "no body", ""),
        (["medic@example.org"], "From lines", "From here\n.\n..dots\n" * 50),
    ],
)
def test_message_bytes_are_the_generators_bytes(
    tmp_path: Path, files: list[Path], to: list[str], subject: str, body: str
) -> None:
    config = BuiltinConfig(outbox_dir=tmp_path / "outbox", attachment_dirs=[tmp_path])
    for attached in (files, files[:1], []):
        built = build_message(config, to, subject, body, attached)
        quick = message_bytes(built)  # chooses and sets the boundary, as the generator would
        assert quick == built.as_bytes()
        assert message_bytes(built, email.policy.SMTP) == built.as_bytes(policy=email.policy.SMTP) == quick
        assert message_bytes(built, email.policy.default) == built.as_bytes(policy=email.policy.default)
        parsed = email.message_from_bytes(quick, policy=email.policy.default)
        assert isinstance(parsed, EmailMessage)
        assert {p.get_filename(): p.get_payload(decode=True) for p in parsed.iter_attachments()} == {
            f.name: f.read_bytes() for f in attached
        }


def test_message_bytes_choose_a_boundary_that_is_not_in_the_message() -> None:
    made = message()
    made.add_attachment(b"x", maintype="application", subtype="octet-stream", filename="x.bin")
    data = message_bytes(made)
    boundary = made.get_boundary()
    assert boundary is not None and boundary.startswith("=" * 15) and boundary.endswith("==")
    assert data.count(f"--{boundary}".encode()) == 3  # two parts and the end


def test_anything_else_goes_to_the_standard_generator() -> None:
    nested = message()
    inner = message()
    inner.add_attachment(b"x", maintype="application", subtype="octet-stream", filename="x.bin")
    nested.add_attachment(inner)  # a message/rfc822 part
    nested.preamble = "This is a MIME message."
    assert message_bytes(nested) == nested.as_bytes()


def test_send_files_still_refuses_too_much(tmp_path: Path) -> None:
    config = BuiltinConfig(outbox_dir=tmp_path / "outbox", attachment_dirs=[tmp_path])
    big = tmp_path / "big.bin"
    with big.open("wb") as file:
        file.truncate(MAX_ATTACHMENTS_BYTES + 1)
    with pytest.raises(ToolError, match="MB limit"):
        send_files(config, ["ops@example.org"], "s", "b", [big])
    assert not (tmp_path / "outbox").exists()


DATE, MESSAGE_ID = "Sun, 22 Nov 2026 06:05:30 +0000", "<179532753037.383.11046770362973036824@localhost>"


@pytest.mark.parametrize(
    ("to", "subject", "body"),
    [
        (["medics@example.org"], "Collapse at 21.4147, 39.8932", "Motionless 40 s at ramp 3; kit released."),
        (["Ops <ops@example.org>", "Medical Team 2 <m2@example.org>"], "two recipients", "line one\nline two\n"),
        ([], "no recipients", ""),
        (["m@example.org"], "  spaced \t subject  ", "a\r\nb\rc\n\n\ttabbed\n"),
        (["m@example.org"], "s" * 69, "x" * 78),  # both at 78 columns: still on one line
        (["m@example.org"], "From lines", "From here\n.\n..dots\n" * 50),
    ],
)
def test_a_plain_alert_is_written_straight_to_the_same_bytes(
    tmp_path: Path, files: list[Path], to: list[str], subject: str, body: str
) -> None:
    config = BuiltinConfig(outbox_dir=tmp_path / "outbox", attachment_dirs=[tmp_path])
    plain_files = [f for f in files if " " not in f.name]  # the runner's names: no quoting needed
    for attached in (plain_files, plain_files[:1], []):
        pairs = [(f.name, f.read_bytes()) for f in attached]
        quick = plain_message(config.smtp_from, to, subject, body, pairs, date=DATE, message_id=MESSAGE_ID)
        assert quick is not None
        built = build_message(config, to, subject, body, attached)
        built.replace_header("Date", DATE)
        built.replace_header("Message-ID", MESSAGE_ID)
        boundary = re.search(rb'boundary="([^"]+)"', quick)
        if attached:
            assert boundary is not None
            built.set_boundary(boundary.group(1).decode())
        assert quick == message_bytes(built) == built.as_bytes()


@pytest.mark.parametrize(
    ("to", "subject", "body", "name"),
    [
        (["m@example.org"], "Kollaps über Rampe 3", "help", "a.png"),  # a subject to encode
        (["m@example.org"], "s", "Hilfe: Person liegt still, Rampe 3 – bitte", "a.png"),  # 8-bit text
        (['"Doe, Jane" <j@example.org>'], "s", "b", "a.png"),  # a name to quote
        (["m@example.org"], "s" * 70, "b", "a.png"),  # a subject to fold
        (["m@example.org"], "s", "x" * 79, "a.png"),  # a line too long for 7 bits
        (["m@example.org"], "=?utf-8?q?x?=", "b", "a.png"),  # looks like an encoded word
        (["m@example.org"], "s", "b", "a b.png"),  # a file name to quote
    ],
)
def test_anything_not_plain_is_left_to_the_standard_library(
    tmp_path: Path, to: list[str], subject: str, body: str, name: str
) -> None:
    assert plain_message("uav@example.org", to, subject, body, [(name, b"x")], date=DATE, message_id=MESSAGE_ID) is None
    config = BuiltinConfig(outbox_dir=tmp_path / "outbox", attachment_dirs=[tmp_path])
    (tmp_path / name).write_bytes(b"x")
    data, message_id = encode_message(config, to, subject, body, [tmp_path / name])
    parsed = email.message_from_bytes(data, policy=email.policy.default)
    assert isinstance(parsed, EmailMessage) and parsed["Message-ID"] == message_id
    assert parsed["Subject"] is not None  # as the standard library writes it (folded, encoded)
    text = parsed.get_body(("plain",))
    assert text is not None and text.get_content().splitlines() == body.splitlines()
    assert [p.get_filename() for p in parsed.iter_attachments()] == [name]


@pytest.mark.parametrize(
    ("to", "subject", "name"),
    [
        (["m@example.org"], "", "a.png"),  # an empty Subject: the header classes write it without its space
        (["m@example.org"], "s", "x.eml"),  # message/rfc822: not a leaf part for the generator
        ([".b@example.org"], "s", "a.png"),  # not a dot-atom: left to the header classes (which refuse it)
        (["m@example.org."], "s", "a.png"),
    ],
)
def test_the_edges_of_plain(to: list[str], subject: str, name: str) -> None:
    assert plain_message("uav@example.org", to, subject, "b", [(name, b"x")], date=DATE, message_id=MESSAGE_ID) is None
