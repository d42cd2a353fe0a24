"""The one egress policy for outbound HTTP: internal addresses are refused after DNS resolution, on every request
of a call (each redirect included), unless configuration allows them.

A model steered by injected text must not turn a webhook or an HTTP tool into a probe of the machine's own
network (server-side request forgery). Refused unless allowlisted: loopback, link-local (169.254/16, fe80::/10,
where cloud metadata lives), private (RFC 1918, fc00::/7), CGNAT (100.64/10), unspecified, multicast and reserved
addresses, and the metadata host names (:data:`METADATA_HOSTS`). The allowlist is the ``AGENTIC_UAV_EGRESS_ALLOW``
variable (comma-separated host names, addresses or networks), the same one :class:`tools.builtin.BuiltinConfig`
reads. The connection goes to the address that was checked (the host name is kept for the ``Host`` header and
TLS), so a name cannot resolve to a public address for the check and a private one for the connection.

>>> policy = EgressPolicy(allow=("127.0.0.1",), resolve=lambda host, port: ["10.0.0.7"])
>>> policy.check("http://127.0.0.1:8080/hook")
'127.0.0.1'
>>> try:
...     policy.check("http://intranet.example/")
... except EgressDenied as exc:
...     print(exc)
egress refused: intranet.example resolves to 10.0.0.7, a private address (allow it in AGENTIC_UAV_EGRESS_ALLOW)
"""

from __future__ import annotations

import asyncio
import ipaddress
import logging
import os
import re
import socket
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field

import httpx

from .errors import ToolError

ENV_VAR = "AGENTIC_UAV_EGRESS_ALLOW"
METADATA_HOSTS = frozenset(
    {
        "metadata",
        "metadata.google.internal",
        "metadata.goog",
        "metadata.azure.com",
        "instance-data",
        "instance-data.ec2.internal",
        "metadata.tencentyun.com",
        "metadata.platformequinix.com",
    }
)
"""Host names of cloud instance-metadata services, refused by name whatever they resolve to."""
_INET_ATON = re.compile(r"[0-9a-fx.]+")
CGNAT = ipaddress.ip_network("100.64.0.0/10")
MAX_REDIRECTS = 5
BODY_CHARS = 500
"""How much of an answer's body goes back to the model (fenced): enough for an error message, not for a dump."""

Address = ipaddress.IPv4Address | ipaddress.IPv6Address
Resolver = Callable[[str, int], list[str]]
log = logging.getLogger(__name__)


class EgressDenied(ToolError):
    """An outbound request to an address the policy refuses; the agent sees it as the call's error."""


def system_resolve(host: str, port: int) -> list[str]:
    """Every address ``host`` resolves to, as the system resolver gives them."""
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except (socket.gaierror, UnicodeError) as exc:
        raise httpx.ConnectError(f"cannot resolve {host}: {exc}") from None
    return list(dict.fromkeys(str(info[4][0]) for info in infos))


def address_kind(address: Address) -> str | None:
    """Why ``address`` is internal (``"loopback"``, ``"private"``...), or None for a public unicast address."""
    if isinstance(address, ipaddress.IPv6Address) and address.ipv4_mapped is not None:
        return address_kind(address.ipv4_mapped)
    checks = (
        ("loopback", address.is_loopback),
        ("link-local", address.is_link_local),
        ("unspecified", address.is_unspecified),
        ("multicast", address.is_multicast),
        ("CGNAT", isinstance(address, ipaddress.IPv4Address) and address in CGNAT),
        ("private", address.is_private),
        ("reserved", address.is_reserved or not address.is_global),
    )
    return next((name for name, hit in checks if hit), None)


def fenced(text: str, limit: int = BODY_CHARS) -> str:
    """At most ``limit`` characters of outside text between markers that say it is data, not instructions.

    >>> fenced("ok", 10)
    '<<<untrusted response body>>>\\nok\\n<<<end>>>'
    """
    body = text[:limit] + (" [...]" if len(text) > limit else "")
    body = body.replace("<<<", "< < <")
    return f"<<<untrusted response body>>>\n{body}\n<<<end>>>"


@dataclass(frozen=True)
class EgressPolicy:
    """Which hosts outbound HTTP may reach. ``allow``: host names (exact, any case), addresses and networks
    (``10.0.0.0/8``) let through although internal; ``resolve(host, port)`` gives a name's addresses. ``hosts``,
    when set, narrows one client to those host names (a webhook's allowlist, named by ``hosts_setting``), checked
    on every request before the rest of the policy."""

    allow: tuple[str, ...] = ()
    resolve: Resolver | None = field(default=None, compare=False, repr=False)  # None: :func:`system_resolve`
    hosts: tuple[str, ...] | None = None
    hosts_setting: str = ""

    @classmethod
    def from_env(cls, environ: Mapping[str, str] | None = None) -> EgressPolicy:
        """The policy ``AGENTIC_UAV_EGRESS_ALLOW`` sets (``os.environ`` unless ``environ``)."""
        raw = (os.environ if environ is None else environ).get(ENV_VAR, "")
        return cls(allow=parse_allow(raw.replace(";", ",").split(",")))

    def check(self, url: str | httpx.URL) -> str:
        """The address to connect to for ``url``; :class:`EgressDenied` when the policy refuses it."""
        url = httpx.URL(url) if isinstance(url, str) else url
        host = url.host.lower().rstrip(".")
        port = url.port or (443 if url.scheme == "https" else 80)
        if url.scheme not in ("http", "https") or not host:
            raise self._refuse(f"{url.scheme}://{host}: only http(s) URLs with a host")
        if self.hosts is not None and host not in self.hosts:
            raise self._refuse(f"{host} is not an allowed host of this client", self.hosts_setting or ENV_VAR)
        if host in self.allow:
            return self._first(host, port)
        if host in METADATA_HOSTS or host == "localhost" or host.endswith(".localhost"):
            raise self._refuse(f"{host} is a metadata or local host name")
        addresses = self._addresses(host, port)
        for address in addresses:
            kind = address_kind(address)
            if kind is not None and not self._allowed(address):
                via = f"{host} is" if host == str(address) else f"{host} resolves to {address},"
                raise self._refuse(f"{via} a{'n' if kind[0] in 'aeiou' else ''} {kind} address")
        return str(addresses[0])

    def _first(self, host: str, port: int) -> str:
        return str(self._addresses(host, port)[0])

    def _addresses(self, host: str, port: int) -> list[Address]:
        try:
            return [ipaddress.ip_address(host)]
        except ValueError:
            pass
        if _INET_ATON.fullmatch(host):  # 2130706433, 0x7f.1, 127.1: what the C library reads as an IPv4 address
            try:
                return [ipaddress.IPv4Address(socket.inet_aton(host))]
            except OSError:
                pass
        resolve = self.resolve or system_resolve
        found = [ipaddress.ip_address(a.split("%", 1)[0]) for a in resolve(host, port)]
        if not found:
            raise httpx.ConnectError(f"cannot resolve {host}: no address")
        return found

    def _allowed(self, address: Address) -> bool:
        for entry in self.allow:
            try:
                if address in ipaddress.ip_network(entry, strict=False):
                    return True
            except ValueError:
                continue
        return False

    def _refuse(self, reason: str, setting: str = ENV_VAR) -> EgressDenied:
        message = f"egress refused: {reason} (allow it in {setting})"
        log.warning(message)
        return EgressDenied(message)


def _is_address(host: str) -> bool:
    try:
        ipaddress.ip_address(host)
    except ValueError:
        return False
    return True


def parse_allow(entries: Iterable[str]) -> tuple[str, ...]:
    """Allowlist entries cleaned: blanks dropped, host names lower-cased."""
    return tuple(e.strip().lower().rstrip(".") for e in entries if e.strip())


def _pinned(request: httpx.Request, address: str) -> httpx.Request:
    """``request`` sent to ``address`` while it still names its host (``Host`` header, TLS server name); the
    caller's request is left as it was, so a relative redirect resolves against the host name."""
    host = request.url.host
    if host == address:
        return request
    return httpx.Request(
        request.method,
        request.url.copy_with(host=address),
        headers=request.headers,
        stream=request.stream,
        extensions={**request.extensions, "sni_hostname": host},
    )


class EgressTransport(httpx.BaseTransport):
    """An httpx transport that checks every request (a redirect is a new request) before it connects."""

    def __init__(self, policy: EgressPolicy, inner: httpx.BaseTransport | None = None) -> None:
        self.policy = policy
        self.inner = inner or httpx.HTTPTransport()

    def handle_request(self, request: httpx.Request) -> httpx.Response:
        return self.inner.handle_request(_pinned(request, self.policy.check(request.url)))

    def close(self) -> None:
        self.inner.close()


class AsyncEgressTransport(httpx.AsyncBaseTransport):
    """The async form of :class:`EgressTransport`; DNS is resolved off the event loop."""

    def __init__(self, policy: EgressPolicy, inner: httpx.AsyncBaseTransport | None = None) -> None:
        self.policy = policy
        self.inner = inner or httpx.AsyncHTTPTransport()

    async def handle_async_request(self, request: httpx.Request) -> httpx.Response:
        literal = _is_address(request.url.host)
        address = self.policy.check(request.url) if literal else await asyncio.to_thread(self.policy.check, request.url)
        return await self.inner.handle_async_request(_pinned(request, address))

    async def aclose(self) -> None:
        await self.inner.aclose()


def guarded_client(policy: EgressPolicy, timeout: float) -> httpx.Client:
    """A client whose every request, redirects followed (up to :data:`MAX_REDIRECTS`), passes ``policy``."""
    return httpx.Client(
        timeout=timeout, transport=EgressTransport(policy), follow_redirects=True, max_redirects=MAX_REDIRECTS
    )


__all__ = [
    "BODY_CHARS",
    "ENV_VAR",
    "MAX_REDIRECTS",
    "METADATA_HOSTS",
    "AsyncEgressTransport",
    "EgressDenied",
    "EgressPolicy",
    "EgressTransport",
    "address_kind",
    "fenced",
    "guarded_client",
    "parse_allow",
    "system_resolve",
]
