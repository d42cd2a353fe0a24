"""A change's request body, bounded: at most :data:`MAX_BODY_BYTES` read (a declared ``Content-Length`` over it is
refused before a byte is read, and a streamed body is cut off at the limit), then parsed as JSON no deeper than
the shared limit (:mod:`agentic_core.contracts.json_depth`). Why: a console's commands are a few dozen bytes, and
neither a huge nor a deeply nested body may cost the live run memory or a traceback.

>>> BodyRefused(413, "too big").status
413
"""

from __future__ import annotations

from collections.abc import AsyncIterator, Mapping
from typing import Any

from ..contracts.errors import InputError
from ..contracts.json_depth import MAX_JSON_DEPTH, JsonTooDeep, loads

MAX_BODY_BYTES = 64 * 1024
"""The largest body a change may carry (a command, an answer with its edits, a fork's checkpoint)."""


class BodyRefused(InputError):
    """A body the console will not take: ``status`` is the HTTP status to answer with (400 or 413)."""

    def __init__(self, status: int, why: str) -> None:
        super().__init__(why)
        self.status = status


def declared_length(headers: Mapping[str, str]) -> int | None:
    """The body's ``Content-Length`` (None when absent); :class:`BodyRefused` when it is not a length.

    >>> declared_length({"content-length": "12"}), declared_length({})
    (12, None)
    """
    text = headers.get("content-length")
    if text is None:
        return None
    if not text.strip().isdigit():
        raise BodyRefused(400, f"Content-Length {text[:40]!r} is not a length")
    return int(text)


async def read_bounded(headers: Mapping[str, str], chunks: AsyncIterator[bytes], limit: int = MAX_BODY_BYTES) -> bytes:
    """The body, read no further than ``limit`` bytes; :class:`BodyRefused` (413) past it."""
    too_big = BodyRefused(413, f"the body is larger than {limit:,} bytes")
    length = declared_length(headers)
    if length is not None and length > limit:
        raise too_big
    body = bytearray()
    async for chunk in chunks:
        body += chunk
        if len(body) > limit:
            raise too_big
    return bytes(body)


def parse_object(body: bytes) -> dict[str, Any]:
    """The body as a JSON object (an empty body is ``{}``); :class:`BodyRefused` (400) saying what is wrong.

    >>> parse_object(b'{"reason": "smoke"}'), parse_object(b"")
    ({'reason': 'smoke'}, {})
    >>> try:
    ...     parse_object(b"[" * 500 + b"]" * 500)
    ... except BodyRefused as exc:
    ...     print(exc.status, exc)
    400 the body is JSON nested more than 100 levels deep
    """
    try:
        value = loads(body or b"{}")
    except JsonTooDeep:
        raise BodyRefused(400, f"the body is JSON nested more than {MAX_JSON_DEPTH} levels deep") from None
    except (ValueError, UnicodeDecodeError):
        raise BodyRefused(400, "the body is not JSON") from None
    if not isinstance(value, dict):
        raise BodyRefused(400, "the body is not a JSON object")
    return value


__all__ = ["MAX_BODY_BYTES", "BodyRefused", "declared_length", "parse_object", "read_bounded"]
