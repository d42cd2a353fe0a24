"""Fixtures of the built-in tool tests: settings in a temporary folder, executors that never wait between
retries, and a local SMTP server (aiosmtpd) that records what it receives."""

from __future__ import annotations

import datetime as dt
import ipaddress
import ssl
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest
from aiosmtpd.controller import Controller
from aiosmtpd.smtp import SMTP, AuthResult, Envelope, LoginPassword, Session

from tools import Caller, ToolExecutor, ToolRegistry
from tools.builtin import BuiltinConfig, register_builtins

from .local_http import free_port

ROOT = Caller(id="tester", scopes=frozenset({"*"}))
SMTP_USER, SMTP_PASSWORD = "drone-ops", "correct horse battery staple"


@pytest.fixture
def config(tmp_path: Path) -> BuiltinConfig:
    """Offline settings: outbox and incident log under the test's folder, short network timeouts."""
    return BuiltinConfig(
        outbox_dir=tmp_path / "outbox",
        incidents_db=tmp_path / "incidents.db",
        attachment_dirs=[tmp_path],
        http_timeout_s=5,
        egress_allow=["127.0.0.1"],  # the tests' HTTP servers; the egress policy refuses loopback otherwise
        webhook_allow=["127.0.0.1"],  # ... and the webhook allowlist any host it does not name
        alert_allow=["@team.example", "@example.org", "@b.example"],  # the addresses the tests mail
    )


@dataclass
class Harness:
    """The built-in tools registered with some settings, and an executor whose backoff sleeps are recorded."""

    registry: ToolRegistry
    executor: ToolExecutor
    delays: list[float] = field(default_factory=list)

    def call(self, name: str, args: dict[str, Any], caller: Caller = ROOT) -> Any:
        return self.executor.call(name, args, caller=caller)


@pytest.fixture
def harness() -> Iterator[Callable[[BuiltinConfig], Harness]]:
    """``harness(config)``: the built-in tools bound to ``config`` behind a fresh executor (closed afterwards)."""
    made: list[ToolExecutor] = []

    def make(settings: BuiltinConfig) -> Harness:
        registry = ToolRegistry()
        register_builtins(registry, settings)
        delays: list[float] = []
        executor = ToolExecutor(registry, default_caller=ROOT, sleep=delays.append)
        made.append(executor)
        return Harness(registry, executor, delays)

    yield make
    for executor in made:
        executor.close()


class Inbox:
    """An aiosmtpd handler keeping what it accepts; ``reject`` addresses get a 550, ``data_reply`` replaces the
    reply to DATA (e.g. a 554 or a 451)."""

    def __init__(self) -> None:
        self.envelopes: list[Envelope] = []
        self.reject: set[str] = set()
        self.data_reply: str | None = None
        self.logins: list[str] = []

    async def handle_RCPT(
        self, server: SMTP, session: Session, envelope: Envelope, address: str, rcpt_options: list[str]
    ) -> str:
        if address in self.reject:
            return f"550 5.1.1 <{address}>: mailbox unavailable"
        envelope.rcpt_tos.append(address)
        return "250 OK"

    async def handle_DATA(self, server: SMTP, session: Session, envelope: Envelope) -> str:
        if self.data_reply is not None:
            return self.data_reply
        self.envelopes.append(envelope)
        return "250 Message accepted for delivery"

    def authenticate(self, server: SMTP, session: Session, envelope: Envelope, mechanism: str, data: Any) -> AuthResult:
        ok = isinstance(data, LoginPassword) and (data.login, data.password) == (
            SMTP_USER.encode(),
            SMTP_PASSWORD.encode(),
        )
        if ok:
            self.logins.append(SMTP_USER)
        return AuthResult(success=ok, handled=False)  # handled=False: aiosmtpd then replies 535 itself


@dataclass
class MailServer:
    inbox: Inbox
    host: str
    port: int
    ca_file: Path | None = None


def _start(inbox: Inbox, **options: Any) -> tuple[Controller, MailServer]:
    port = free_port()
    controller = Controller(inbox, hostname="127.0.0.1", port=port, **options)
    controller.start()
    return controller, MailServer(inbox, "127.0.0.1", port)


@pytest.fixture
def smtp_server() -> Iterator[MailServer]:
    """A plain SMTP server (no TLS, no login) on a free local port."""
    controller, server = _start(Inbox())
    yield server
    controller.stop()


def self_signed(folder: Path) -> tuple[Path, Path]:
    """A certificate for 127.0.0.1 and its key, made now (cryptography is only needed by the STARTTLS tests)."""
    x509 = pytest.importorskip("cryptography.x509")
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.x509.oid import NameOID

    key = ec.generate_private_key(ec.SECP256R1())
    name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "127.0.0.1")])
    now = dt.datetime.now(dt.UTC)
    certificate = (
        x509.CertificateBuilder()
        .subject_name(name)
        .issuer_name(name)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - dt.timedelta(minutes=5))
        .not_valid_after(now + dt.timedelta(days=1))
        .add_extension(x509.SubjectAlternativeName([x509.IPAddress(ipaddress.ip_address("127.0.0.1"))]), False)
        .add_extension(x509.BasicConstraints(ca=True, path_length=None), True)
        .sign(key, hashes.SHA256())
    )
    cert_file, key_file = folder / "smtp-cert.pem", folder / "smtp-key.pem"
    cert_file.write_bytes(certificate.public_bytes(serialization.Encoding.PEM))
    key_file.write_bytes(
        key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8, serialization.NoEncryption())
    )
    return cert_file, key_file


@pytest.fixture
def tls_smtp_server(tmp_path: Path) -> Iterator[MailServer]:
    """An SMTP server that requires STARTTLS and then a login (SMTP_USER / SMTP_PASSWORD)."""
    cert_file, key_file = self_signed(tmp_path)
    context = ssl.create_default_context(ssl.Purpose.CLIENT_AUTH)
    context.load_cert_chain(cert_file, key_file)
    inbox = Inbox()
    controller, server = _start(
        inbox,
        tls_context=context,
        require_starttls=True,
        auth_required=True,
        authenticator=inbox.authenticate,
    )
    server.ca_file = cert_file
    yield server
    controller.stop()
