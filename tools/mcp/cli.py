"""``agentic-uav mcp serve``: offer the registry's tools to MCP clients on stdio (default) or Streamable HTTP.

Over stdio the caller is the local user holding ``--scopes``; over HTTP each request's bearer token names the caller
(secret in ``AGENTIC_UAV_TOKEN_SECRET``; without it the server binds only to loopback and every request is the local
user, who may then hold no ``flight:`` or ``alerts:`` scope; ``agentic-uav mcp token NAME --scopes ...`` prints a
client's token). The tools are the built-ins (unless ``--no-builtins``), installed plugins and every ``--tools`` source.

>>> args = build_parser().parse_args(["serve", "--no-builtins", "--scopes", "weather:read,map:*"])
>>> args.http, args.host, len(registry_from_args(args)), sorted(local_caller(args.scopes).scopes)
(False, '127.0.0.1', 0, ['map:*', 'weather:read'])
"""

from __future__ import annotations

import argparse
import getpass
import logging
import signal
import sys
import threading
from collections.abc import Sequence

from ..audit import open_audit_log
from ..auth import SECRET_ENV, Caller, TokenAuthority
from ..cli import add_source_options, registry_from_args
from ..errors import ToolDefinitionError
from ..executor import ToolExecutor
from .http_transport import serve_http
from .server import McpServer, serve_stdio

DEFAULT_PORT = 8765


def build_parser(prog: str = "agentic-uav mcp") -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog=prog, description="Model Context Protocol server for the agentic-uavs tools")
    commands = parser.add_subparsers(dest="command", required=True)
    serve = commands.add_parser("serve", help="serve the tools to MCP clients (stdio unless --http)")
    serve.add_argument("--http", action="store_true", help="serve Streamable HTTP at /mcp instead of stdio")
    serve.add_argument("--host", default="127.0.0.1", help="address to bind (other than loopback needs a token secret)")
    serve.add_argument("--port", type=int, default=DEFAULT_PORT, help=f"port (default {DEFAULT_PORT}; 0: a free one)")
    serve.add_argument(
        "--scopes",
        nargs="*",
        default=[],
        metavar="SCOPE",
        help="scopes of the local caller, e.g. weather:read map:*",
    )
    add_source_options(serve)
    serve.add_argument("--audit", metavar="PATH", help="write the audit log to PATH (.jsonl or .db)")
    serve.add_argument("-v", "--verbose", action="store_true", help="log debugging detail to stderr")
    token = commands.add_parser("token", help=f"print a bearer token for an HTTP client, signed with {SECRET_ENV}")
    token.add_argument("subject", help="who the client is (its sessions and audit records carry this name)")
    token.add_argument("--scopes", nargs="*", default=[], metavar="SCOPE", help="scopes it holds, e.g. flight:*")
    token.add_argument("--ttl", type=float, default=3600.0, metavar="SECONDS", help="lifetime (default 3600 s)")
    return parser


def local_caller(scopes: Sequence[str]) -> Caller:
    """The user running the server, holding ``scopes`` (each may also be a comma-separated list)."""
    try:
        user = getpass.getuser()
    except (OSError, KeyError):
        user = "user"
    held = {s.strip() for item in scopes for s in item.split(",") if s.strip()}
    return Caller(id=f"local:{user}", scopes=frozenset(held))


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.command == "token":
        return _token(args)
    logging.basicConfig(stream=sys.stderr, level=logging.DEBUG if args.verbose else logging.WARNING)
    try:
        registry = registry_from_args(args)
        audit = open_audit_log(args.audit) if args.audit else None
        authority = TokenAuthority.from_env() if args.http else None
    except (ImportError, ToolDefinitionError, ValueError, OSError) as exc:
        print(f"agentic-uav mcp: {exc}", file=sys.stderr)
        return 2
    caller = local_caller(args.scopes)
    executor = ToolExecutor(registry, audit=audit, default_caller=caller)
    server = McpServer(executor)
    try:
        return _serve_http(server, args, authority) if args.http else _serve_stdio(server, caller)
    finally:
        executor.close()


def _token(args: argparse.Namespace) -> int:
    try:
        authority = TokenAuthority.from_env()
        if authority is None:
            raise ValueError(f"set {SECRET_ENV} to the server's secret (32+ bytes) to sign tokens")
        print(authority.issue(args.subject, local_caller(args.scopes).scopes, ttl_s=args.ttl))
    except ValueError as exc:
        print(f"agentic-uav mcp: {exc}", file=sys.stderr)
        return 2
    return 0


def _serve_stdio(server: McpServer, caller: Caller) -> int:
    previous = sys.stdout
    sys.stdout = sys.stderr  # a stray print() must not corrupt the protocol stream
    try:
        serve_stdio(server, sys.stdin.buffer, previous.buffer, caller=caller)
    finally:
        sys.stdout = previous
    return 0


def _serve_http(server: McpServer, args: argparse.Namespace, authority: TokenAuthority | None) -> int:
    try:
        handle = serve_http(server, args.host, args.port, authority)
    except ValueError as exc:
        print(f"agentic-uav mcp: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"agentic-uav mcp: cannot listen on {args.host}:{args.port}: {exc}", file=sys.stderr)
        return 1
    auth = "bearer tokens required" if authority else "no token: local caller"
    print(f"MCP server on {handle.url} ({len(server.registry)} tools; {auth})", file=sys.stderr, flush=True)
    stop = threading.Event()
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, lambda *_: stop.set())
    try:
        while not stop.wait(0.5):
            pass
    except KeyboardInterrupt:
        pass
    finally:
        handle.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
