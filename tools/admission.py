"""The stages of a call before its tool runs, each a finished result when the call stops there: lookup (an unknown
tool gets a did-you-mean), argument validation (and the idempotency key's form), authorization (a token verified
first), then rate limit, cache and circuit breaker."""

from __future__ import annotations

import copy
from collections.abc import Mapping

from .arguments import argument_errors
from .attempts import CallState
from .audit import AuditLog
from .auth import InvalidToken, TokenAuthority, unverified_caller
from .call_end import finish
from .idempotency import key_problem
from .registry import ToolRegistry, is_available
from .result import ToolResult


def admit(
    call: CallState, registry: ToolRegistry, authority: TokenAuthority | None, audit: AuditLog, *, closed: bool
) -> ToolResult | None:
    """Lookup to authorization: a finished result when the call stops there, else None."""
    if closed:
        call.stage("lookup", "failed", "closed")
        return finish(audit, call, "error", error="the tool executor is closed")
    entry = registry.entry(call.name) or registry.entry(registry.resolve(call.name))
    if entry is None:
        call.stage("lookup", "failed")
        closest = registry.closest(call.name)
        hint = f"; did you mean {', '.join(repr(c) for c in closest)}?" if closest else ""
        return finish(audit, call, "error", error=f"unknown tool {call.name!r}{hint}")
    spec = entry.spec
    call.entry, call.name = entry, spec.name
    if spec.available is not None and not is_available(spec):
        call.stage("lookup", "failed", "unavailable")
        return finish(audit, call, "error", error=f"tool {spec.name!r} is not available now")
    call.stage("lookup", "passed")

    if not isinstance(call.args, Mapping):
        call.stage("validate_args", "failed")
        return finish(audit, call, "error", error=f"invalid arguments: expected an object, got {call.args!r}")
    call.args = dict(call.args)
    detail = argument_errors(entry, call.args)
    if detail is not None:
        call.stage("validate_args", "failed", detail)
        return finish(audit, call, "error", error=f"invalid arguments: {detail}")
    if call.key is not None:
        problem = key_problem(call.key)
        if problem is not None:
            call.key = None  # not a key: not recorded as one
            call.stage("validate_args", "failed", problem)
            return finish(audit, call, "error", error=f"invalid call: {problem}")
    call.stage("validate_args", "passed")

    denial = authenticate(call, authority)
    if denial is None:
        missing = call.caller.missing(spec.scopes)
        denial = f"{call.caller.id!r} lacks scope {', '.join(missing)}" if missing else None
    if denial is not None:
        call.stage("authorize", "failed", denial)
        return finish(audit, call, "denied", error=denial)
    call.stage("authorize", "passed")
    return None


def guard(call: CallState, audit: AuditLog) -> ToolResult | None:
    """Rate limit to breaker: a finished result when the call stops before the tool runs, else None."""
    entry = call.entry
    assert entry is not None
    spec = entry.spec
    if entry.limiter is not None:
        admitted, wait = entry.limiter.acquire(call.caller.id)
        if not admitted:
            call.stage("rate_limit", "failed", f"retry in {wait:.3g} s")
            return finish(audit, call, "rate_limited", error=f"rate limit reached for {spec.name}", retry=wait)
        call.stage("rate_limit", "passed")

    if entry.cache is not None:
        hit, cached = entry.cache.get(call.args)
        if hit:
            call.stage("cache", "hit")
            value, report = cached
            return finish(audit, call, "ok", output=copy.deepcopy(value), cached=True, injection=report)
        call.stage("cache", "miss")

    allowed, wait, call.is_probe = entry.breaker.admit()
    if not allowed:
        call.stage("circuit_breaker", "failed", f"open; a probe in {wait:.3g} s")
        return finish(audit, call, "circuit_open", error=f"{spec.name} is failing; circuit open", retry=wait)
    call.awaits_verdict = True
    call.stage("circuit_breaker", "passed")
    return None


def authenticate(call: CallState, authority: TokenAuthority | None) -> str | None:
    """Why a call's token is refused, or None (no token, or a valid one: then it names the caller)."""
    if call.token is None:
        return None
    if authority is None:
        call.caller = unverified_caller(call.token)
        return "a token was given, but this executor has no token authority to verify it"
    try:
        call.caller = authority.verify(call.token)
    except InvalidToken as exc:
        call.caller = unverified_caller(call.token)  # recorded as whom it claims to be, never as the default
        return str(exc)
    return None


__all__ = ["admit", "authenticate", "guard"]
