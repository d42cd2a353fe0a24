"""Text folding for the injection guard: the views the patterns run on, and a map back to the original offsets.

A view removes invisible characters and folds case, compatibility forms (full-width, ligatures, math letters),
diacritics and a few Cyrillic/Greek look-alikes, so that simple evasions meet the same patterns as plain text.
"""

from __future__ import annotations

import re
import unicodedata
from bisect import bisect_right
from dataclasses import dataclass
from functools import lru_cache

# Invisible characters: format controls (zero-width, bidi, word joiner, tags, BOM, soft hyphen), variation
# selectors, Hangul fillers and the C0/C1 controls other than tab and line breaks. The Arabic number signs and
# other prepended concatenation marks (also category Cf) are visible and stay.
INVISIBLE_CLASS = (
    "\u00ad\u034f\u061c\u115f\u1160\u17b4\u17b5\u180b-\u180f\u200b-\u200f\u202a-\u202e\u2060-\u2064"
    "\u2066-\u206f\u3164\ufe00-\ufe0f\ufeff\uffa0\ufff9-\ufffb\U00013430-\U00013438\U0001bca0-\U0001bca3"
    "\U0001d173-\U0001d17a\U000e0001\U000e0020-\U000e007f\U000e0100-\U000e01ef"
    "\x00-\x08\x0e-\x1f\x7f-\x84\x86-\x9f"
)
INVISIBLE_RE = re.compile(f"[{INVISIBLE_CLASS}]")

# Lower-case Cyrillic and Greek letters that pass for Latin ones (after case folding); the Urdu and Persian forms
# of Arabic letters (yeh, keheh, heh goal, teh marbuta goal, alef maksura) as the Arabic ones, so that one pattern
# reads both scripts; the tatweel (a stretching stroke, no letter) removed.
_CONFUSABLES = str.maketrans(
    "аеорсухіјѕԁɡԛԝвкмнтıαεικνορτυχωγ\u06cc\u06a9\u06c1\u06c3\u0649",
    "aeopcyxijsdgqwbkmhtiaeiknoptuxwy\u064a\u0643\u0647\u0629\u064a",
    "\u0640",
)
# Leetspeak digits and signs read as letters; applied to the "lex" view only, so numbers and URLs stay intact.
_LEET_BYTES = bytes.maketrans(b"013457@$", b"oieastas")
_ASCII_CONTROLS = bytes(range(0x09)) + bytes(range(0x0E, 0x20)) + b"\x7f"


@lru_cache(maxsize=16384)
def fold_char(c: str) -> str:
    """One character folded: removed if invisible, else NFKD without marks, lower-cased, look-alikes to Latin."""
    if c.isascii():
        return "" if INVISIBLE_RE.match(c) else c.lower()
    if INVISIBLE_RE.match(c):
        return ""
    category = unicodedata.category(c)
    if category in ("Zl", "Zp"):
        return "\n"
    if category == "Zs":
        return " "
    if category in ("Mn", "Me"):
        return ""
    decomposed = unicodedata.normalize("NFKD", c)
    kept = "".join(ch for ch in decomposed if unicodedata.category(ch) not in ("Mn", "Me"))
    return kept.lower().translate(_CONFUSABLES)


def fold(text: str) -> str:
    """The folded form of ``text`` (used to write non-English patterns in their own script)."""
    return "".join(fold_char(c) for c in text)


@dataclass(slots=True)
class Views:
    """The scanned text, its folded ``raw`` view and the leetspeak-read ``lex`` view (same length as ``raw``).

    ``runs`` are the runs of characters whose folded form is not one character (invisibles, ligatures), as
    ``(start in text, length in text, start in raw, length in raw)``: all that is needed to map offsets back.
    """

    text: str
    raw: str
    lex: str
    runs: tuple[tuple[int, int, int, int], ...] = ()
    _starts: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        self._starts = tuple(run[2] for run in self.runs)

    def span(self, start: int, end: int) -> tuple[int, int]:
        """The original span that folds to ``raw[start:end]``."""
        if not self.runs:
            return start, end
        first = self._orig(start, end=False)
        return first, max(first, self._orig(end - 1, end=True) if end > start else first)

    def _orig(self, pos: int, *, end: bool) -> int:
        k = bisect_right(self._starts, pos) - 1
        if k < 0:
            orig = pos + end
        else:
            o_start, o_len, n_start, n_len = self.runs[k]
            if pos < n_start + n_len:  # inside a run: its start, or its end for an end offset
                orig = o_start + o_len if end else o_start
            else:
                orig = o_start + o_len + pos - n_start - n_len + end
        return min(orig, len(self.text))


_SPECIAL = re.compile(r"[^\x09-\x0d\x20-\x7e]+")  # what lower-casing does not fold: non-ASCII and controls


def make_views(text: str) -> Views:
    """Fold ``text`` once: pure ASCII (the common case) only needs lower-casing, mostly-ASCII text a few runs."""
    if text.isascii():
        data = text.lower().encode("ascii")
        if len(data.translate(None, _ASCII_CONTROLS)) == len(data):
            return Views(text, data.decode("ascii"), data.translate(_LEET_BYTES).decode("ascii"))
    lowered = (text.replace("\u0130", "I") if "\u0130" in text else text).lower()  # U+0130 alone grows lower-cased
    if (len(text.encode("utf-8", "surrogatepass")) - len(text)) * 8 > len(text):
        return _fold_all(text)
    pieces: list[str] = []
    runs: list[tuple[int, int, int, int]] = []
    done = shift = 0
    for m in _SPECIAL.finditer(lowered):
        folds = [fold_char(c) for c in m.group()]
        folded = "".join(folds)
        if folded == m.group():
            continue
        pieces += [lowered[done : m.start()], folded]
        done = m.end()
        if len(folded) == len(folds) and all(len(f) == 1 for f in folds):
            continue
        for i, f in enumerate(folds):  # exact runs for the characters that fold to other than one character
            if len(f) != 1:
                if runs and runs[-1][0] + runs[-1][1] == m.start() + i:
                    o_start, o_len, n_start, n_len = runs.pop()
                    runs.append((o_start, o_len + 1, n_start, n_len + len(f)))
                else:
                    runs.append((m.start() + i, 1, m.start() + i + shift, len(f)))
                shift += len(f) - 1
    raw = "".join([*pieces, lowered[done:]])
    return Views(text, raw, _leet(raw), tuple(runs))


def _leet(raw: str) -> str:
    return raw.encode("utf-8", "surrogatepass").translate(_LEET_BYTES).decode("utf-8", "surrogatepass")


def _fold_all(text: str) -> Views:
    """Fold text that is mostly not ASCII with one translation table (cheaper than run by run)."""
    table: dict[int, str] = {}
    odd: list[str] = []
    for c in set(text):
        folded = fold_char(c)
        if folded != c:
            table[ord(c)] = folded
        if len(folded) != 1:
            odd.append(c)
    raw = text.translate(table)
    if not odd:
        return Views(text, raw, _leet(raw))
    finder = re.compile("[" + "".join(re.escape(c) for c in odd) + "]+")
    runs: list[tuple[int, int, int, int]] = []
    shift = 0
    lengths = {c: len(table[ord(c)]) for c in odd}
    for m in finder.finditer(text):
        run = m.group()
        length = lengths[run] if len(run) == 1 else sum(map(lengths.__getitem__, run))
        runs.append((m.start(), m.end() - m.start(), m.start() + shift, length))
        shift += length - (m.end() - m.start())
    return Views(text, raw, _leet(raw), tuple(runs))
