"""Hidden text for the injection guard: encoded blobs to decode and rescan, and invisible characters that hide text.

``blobs`` finds base64, hex, Unicode-tag, variation-selector and right-to-left-override segments and decodes each
to readable text (or drops it); ``unescaped`` decodes percent-escapes, HTML character references and ``\\u``
escapes in the whole text. The guard scans what comes out.
``invisible_hits`` weighs the invisible characters themselves.
"""

from __future__ import annotations

import binascii
import html
import re
from collections.abc import Iterator
from dataclasses import dataclass
from itertools import islice
from urllib.parse import unquote

OPAQUE = frozenset({"base64", "hex", "tags", "variation-selectors"})


@dataclass(frozen=True, slots=True)
class Blob:
    """A segment ``text[start:end]`` and the readable text it decodes to."""

    start: int
    end: int
    decoded: str
    how: str

    @property
    def opaque(self) -> bool:
        """Unreadable before decoding (base64, hex, invisible): any instruction-like text inside is suspect."""
        return self.how in OPAQUE


_B64 = re.compile(r"(?<![A-Za-z0-9+/_-])[A-Za-z0-9+/_-]{20,}={0,2}")
_HEX = (  # plain, "\\x"-escaped and "0x"-prefixed; one regex each keeps the prefix scan fast
    re.compile(r"[0-9A-Fa-f]{2}(?:[ :]?[0-9A-Fa-f]{2}){11,}+"),
    re.compile(r"(?:\\x[0-9A-Fa-f]{2}){8,}+"),
    re.compile(r"(?:0x[0-9A-Fa-f]{2},? ?){8,}+"),
)
_ESCAPE = re.compile(r"%[0-9A-Fa-f]{2}|&#(?:[xX][0-9A-Fa-f]{1,6}|[0-9]{1,7});?|\\u[0-9A-Fa-f]{4}")
_TAGS = re.compile("[\U000e0001\U000e0020-\U000e007f]{4,}")
_TAG_TO_ASCII = {0xE0000 + c: c for c in range(0x80)}
_SELECTORS = re.compile("[\ufe00-\ufe0f\U000e0100-\U000e01ef]{4,}")
_RLO = re.compile("[\u202e\u202d]([^\u202a-\u202e\u2066-\u2069\n]{1,4000})")
_NONTEXT = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f\ufffd]+")
_NOT_LETTER = re.compile(r"[\W\d_]+")
_NOT_HEX = re.compile(r"[^0-9A-Fa-f]+")
_UNICODE_ESCAPE = re.compile(r"\\u([0-9A-Fa-f]{4})")


def _readable(data: bytes) -> str | None:
    """``data`` as text if it is text: valid UTF-8 (or UTF-16), few control characters, mostly letters."""
    if len(data) < 8:
        return None
    try:
        text = data.decode("utf-16-le") if data.count(0) * 3 > len(data) else data.decode("utf-8")
    except UnicodeDecodeError:
        return None
    return text if _looks_like_text(text) else None


def _looks_like_text(text: str) -> bool:
    n = len(text)  # counted by what a substitution leaves: a list of every match would cost 60 bytes a character
    if n < 6 or (n - len(_NONTEXT.sub("", text))) * 20 > n:
        return False
    return len(_NOT_LETTER.sub("", text)) * 3 >= n


def _b64decode(run: str) -> str | None:
    core = "".join(run.split()).rstrip("=").replace("-", "+").replace("_", "/")
    for shift in range(4):  # the blob may start mid-quantum when glued to a word
        part = core[shift:]
        part = part[: len(part) - len(part) % 4]
        try:
            text = _readable(binascii.a2b_base64(part))
        except binascii.Error:
            continue
        if text is not None:
            return text
    return None


def _base64_runs(text: str) -> Iterator[tuple[int, int]]:
    """Base64 runs, with the lines of a wrapped (MIME-style) blob joined into one run."""
    start = end = -1
    for m in _B64.finditer(text):
        joinable = end >= 0 and (end - start) % 4 == 0 and text[end - 1] != "=" and m.start() - end <= 4
        if joinable and text[end : m.start()].isspace():
            end = m.end()
            continue
        if start >= 0:
            yield start, end
        start, end = m.start(), m.end()
    if start >= 0:
        yield start, end


def unescaped(text: str) -> Blob | None:
    """``text`` with its percent-escapes, HTML character references and ``\\u`` escapes decoded, if it has three.

    These encodings stay half readable, so the whole text is decoded (and rescanned) rather than each run.
    """
    first = _ESCAPE.search(text)
    if first is None:
        return None
    last, count = first, 1
    for m in _ESCAPE.finditer(text, first.end()):
        last, count = m, count + 1
    if count < 3:
        return None
    decoded = _UNICODE_ESCAPE.sub(lambda e: chr(int(e.group(1), 16)), text) if "\\u" in text else text
    if "&" in decoded:
        decoded = html.unescape(decoded)
    if "%" in decoded:
        decoded = unquote(decoded, errors="replace")
    return Blob(first.start(), last.end(), decoded, "escapes") if decoded != text else None


# Four or more letters, each after one or two separators; possessive, as a backtracking repeat of a group costs
# the regex engine tens of bytes a character. A run glued to a word ("a b c d ef") gives its last letter back.
_SPACED = re.compile(r"(?<![^\W_])[^\W\d_](?:[ .*_-]{1,2}[^\W\d_]){3,}+")
_WORD_CHAR = re.compile(r"[^\W_]")
_SEPARATOR = " .*_-"
_UNSPACE = str.maketrans("", "", _SEPARATOR)


def _spaced_runs(raw: str) -> Iterator[tuple[int, int]]:
    """The spans of spelt-out runs: four letters or more, not inside a word."""
    for m in _SPACED.finditer(raw):
        start, end = m.span()
        if end < len(raw) and _WORD_CHAR.match(raw, end):
            end -= 2 if raw[end - 3] in _SEPARATOR else 1  # the last letter and the separators before it
            end -= 1
            if sum(1 for c in raw[start:end] if c not in _SEPARATOR) < 4:
                continue
        yield start, end


def despaced(raw: str) -> Blob | None:
    """``raw`` (a folded view) with letters spelt out one by one ("i g n o r e") joined up, if it has any."""
    parts: list[str] = []
    done, first = 0, -1
    for start, end in _spaced_runs(raw):
        joined = raw[start:end].translate(_UNSPACE)
        if not joined.isalpha():  # a letter to the regex, not to str.isalpha ("²"): dropped
            joined = "".join(c for c in joined if c.isalpha())
        parts += [raw[done:start], joined]
        done, first = end, start if first < 0 else first
    if first < 0:
        return None
    parts.append(raw[done:])
    return Blob(first, done, "".join(parts), "spaced")


def blobs(text: str, *, hidden: bool = True) -> Iterator[Blob]:
    """Every encoded segment of ``text`` that decodes to readable text; ``hidden``: look for invisible ones too."""
    for start, end in _base64_runs(text):
        decoded = _b64decode(text[start:end])
        if decoded is not None:
            yield Blob(start, end, decoded, "base64")
    for regex in _HEX:
        for m in regex.finditer(text):
            digits = m.group().replace("\\x", "").replace("0x", "")
            pairs = _NOT_HEX.sub("", digits)  # the separators and prefixes gone, the pairs stay aligned
            decoded = _readable(bytes.fromhex(pairs[: len(pairs) - len(pairs) % 2]))
            if decoded is not None:
                yield Blob(m.start(), m.end(), decoded, "hex")
    if hidden and not text.isascii():
        yield from _hidden_blobs(text)


def _hidden_blobs(text: str) -> Iterator[Blob]:
    for m in _TAGS.finditer(text):
        decoded = m.group().translate(_TAG_TO_ASCII).strip("\x01\x7f")
        if len(decoded) >= 7 or " " in decoded:  # shorter runs are flag emoji (England is "gbeng")
            yield Blob(m.start(), m.end(), decoded, "tags")
    for m in _SELECTORS.finditer(text):
        data = bytes(ord(c) - 0xFE00 if ord(c) < 0xFE10 else ord(c) - 0xE0100 + 16 for c in m.group())
        readable = _readable(data)
        if readable is not None:
            yield Blob(m.start(), m.end(), readable, "variation-selectors")
    for m in _RLO.finditer(text):
        yield Blob(m.start(), m.end(), m.group(1)[::-1], "bidi-override")


_ZW_RUN = re.compile("[\u200b\u200c\u200d\u2060-\u2064\ufeff\u180e\u034f]{4,}")
_ZW_IN_WORD = re.compile("(?<=[A-Za-z])[\u200b\u200c\u200d\u2060-\u2064\ufeff\u180e]+(?=[A-Za-z])")
_BIDI_OVERRIDE = re.compile("[\u202d\u202e]")


def invisible_hits(text: str, limit: int) -> list[tuple[str, int, int, float]]:
    """``(rule, start, end, weight)`` for invisible characters that hide or split text, at most ``limit`` a rule."""
    if text.isascii():
        return []
    hits = [("zero_width_run", m.start(), m.end(), 0.6) for m in islice(_ZW_RUN.finditer(text), limit)]
    inside = [(m.start(), m.end()) for m in islice(_ZW_IN_WORD.finditer(text), limit)]
    weight = min(0.45, 0.15 * len(inside))  # one stray joiner is a copy-paste accident; many split keywords
    hits += [("zero_width_in_word", s, e, weight) for s, e in inside]
    hits += [("bidi_override", m.start(), m.end(), 0.5) for m in islice(_BIDI_OVERRIDE.finditer(text), limit)]
    return hits
