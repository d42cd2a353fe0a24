"""What an MCP server without tokens may not offer: physical (``flight:``) and sending (``alerts:``) scopes.

Without a token authority every HTTP request is the one local caller, so any process on the machine holds its
scopes; the server refuses to start rather than let two unauthenticated requests land a drone.

>>> from tools.auth import Caller
>>> forbidden_scopes(Caller(id="local", scopes=frozenset({"weather:read", "flight:*", "alerts:send"})))
['alerts:send', 'flight:*']
>>> check_anonymous(Caller(id="local", scopes=frozenset({"weather:read"})))
"""

from __future__ import annotations

from agentic_core.contracts.errors import InputError

from ..auth import SECRET_ENV, Caller

FORBIDDEN_NAMESPACES = ("flight", "alerts")


def forbidden_scopes(caller: Caller) -> list[str]:
    """The scopes ``caller`` holds that reach a physical or sending tool (``*`` reaches them all), sorted."""
    return sorted(s for s in caller.scopes if s == "*" or (":" in s and s.split(":")[0] in FORBIDDEN_NAMESPACES))


def check_anonymous(caller: Caller) -> None:
    """Refuse (:class:`InputError`) to serve ``caller`` to unauthenticated requests if it holds a forbidden scope."""
    held = forbidden_scopes(caller)
    if held:
        raise InputError(
            f"refusing to serve scope {', '.join(held)} over HTTP without a token: any local process could fly the "
            f"drone or send alerts. Set {SECRET_ENV} to a secret of 32+ bytes (e.g. "
            f"`export {SECRET_ENV}=$(openssl rand -hex 32)`) and give each client a bearer token from "
            f"`agentic-uav mcp token NAME --scopes SCOPE...`, or serve only other scopes."
        )
