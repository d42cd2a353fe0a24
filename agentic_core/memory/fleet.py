"""The fleet's memory: what runs found, kept in one :class:`SqliteStore` file that every run of the fleet shares.

Memories live under ``("memory", kind)`` (kinds: :data:`~agentic_core.contracts.memory.MEMORY_KINDS`), keyed
``<run id>:<trace seq>``, each with the place it concerns and its provenance; knowledge chunks under
``("knowledge", document)``. :meth:`FleetMemory.recall` finds those near a place (and, with a query, by meaning);
:meth:`FleetMemory.why` follows a memory back through what it was recorded from and the memories it cited.

>>> fleet = FleetMemory(":memory:", embed=False)
>>> fleet.remember("incident", "R1:8", "west gate: 104 persons", lat=21.413, lon=39.889,
...                provenance=Provenance(run_id="R1", seq=8, step="patrol/log_west#1", sim_t=103.8))
'incident/R1:8'
>>> [r.key for r in fleet.recall(21.4131, 39.889, within_m=200)]
['R1:8']
"""

from __future__ import annotations

import re
import time
from pathlib import Path
from typing import Any

from agentic_core.contracts.errors import InputError
from agentic_core.contracts.geodesy import distance_m
from agentic_core.contracts.memory import MEMORY_KINDS, MemoryKind, Provenance, Recollection

from .embed import available as model_available
from .filters import near
from .items import Item
from .store import SqliteStore

ROOT = "memory"
CITATION = re.compile(r"\[memory ([a-z]+)/([^\]\s]+)\]")


def split_key(text: str) -> tuple[MemoryKind, str]:
    """``"incident/R1:8"`` → ``("incident", "R1:8")``; InputError naming the kinds when it is not one."""
    kind, sep, key = text.partition("/")
    if not sep or kind not in MEMORY_KINDS or not key:
        raise InputError(f"memory key {text!r}: expected KIND/KEY with KIND one of {', '.join(MEMORY_KINDS)}")
    return kind, key


class FleetMemory:
    """Record, recall and explain memories. ``embed``: use the offline model (None: when it is installed)."""

    def __init__(self, path: str | Path, *, embed: bool | None = None) -> None:
        use = model_available() if embed is None else embed
        index: dict[str, Any] = {"fields": ["text"]}
        if use:
            index |= {"dims": 384, "embed": "all-MiniLM-L6-v2"}
        self.path = path
        self.store = SqliteStore(path, index=index)

    @property
    def search_mode(self) -> str:
        """How a query is ranked here, for the output: the model and BM25, or BM25 alone (and why)."""
        if self.store.embedder is None:
            return "BM25 only (the embed extra is not installed)"
        return self.store.embedding

    def remember(
        self,
        kind: MemoryKind,
        key: str,
        text: str,
        *,
        lat: float | None = None,
        lon: float | None = None,
        severity: str | None = None,
        provenance: Provenance | None = None,
        cites: list[str] | None = None,
        **extra: Any,
    ) -> str:
        """Store one memory; returns its ``kind/key`` (what ``memory why`` takes)."""
        value: dict[str, Any] = {
            "text": text,
            "kind": kind,
            "severity": severity,
            "provenance": (provenance or Provenance()).model_dump(exclude_none=True),
            "recorded_t": time.time(),
            "cites": list(cites or []),
            **extra,
        }
        if lat is not None and lon is not None:
            value["where"] = {"lat": lat, "lon": lon}
        self.store.put((ROOT, kind), key, value)
        return f"{kind}/{key}"

    def recall(
        self,
        lat: float,
        lon: float,
        *,
        within_m: float = 200.0,
        kinds: tuple[MemoryKind, ...] = ("incident", "casualty", "alert", "decision"),
        query: str | None = None,
        limit: int = 5,
        exclude_run: str | None = None,
    ) -> list[Recollection]:
        """Believed memories of ``kinds`` within ``within_m`` of a place, nearest first (ranked by ``query`` if
        given); ``exclude_run`` leaves out a run's own memories."""
        found: list[Recollection] = []
        for kind in kinds:
            for item in self.store.search((ROOT, kind), query=query, filter={"where": near(lat, lon, within_m)},
                                          limit=limit * 4):  # fmt: skip
                r = self._recollection(item, lat, lon)
                if exclude_run is None or r.provenance.run_id != exclude_run:
                    found.append(r)
        if query is None:
            found.sort(key=lambda r: (r.distance_m if r.distance_m is not None else float("inf"), r.key))
        return found[:limit]

    def why(self, text: str) -> list[str]:
        """The chain behind a memory, one line each: what it says, its provenance, every change to it, and the same
        for each memory it cited (depth first, each once)."""
        lines: list[str] = []
        self._why(text, 0, set(), lines)
        return lines

    def _why(self, text: str, depth: int, seen: set[str], lines: list[str]) -> None:
        kind, key = split_key(text)
        pad = "  " * depth
        if text in seen:
            lines.append(f"{pad}{text}: (above)")
            return
        seen.add(text)
        item = self.store.get((ROOT, kind), key)
        if item is None:
            lines.append(f"{pad}{text}: not in this memory")
            return
        v = item.value
        where = v.get("where")
        at = f" at {where['lat']:.5f}, {where['lon']:.5f}" if isinstance(where, dict) else ""
        lines.append(f"{pad}{text}: {v.get('text')}{at}")
        prov = ", ".join(f"{k} {val}" for k, val in v.get("provenance", {}).items())
        lines.append(f"{pad}  from: {prov or 'unknown'}")
        for event in self.store.history((ROOT, kind), key):
            said = f" ({event['reason']}" + (f", by {event['by']})" if event["by"] else ")") if event["reason"] else ""
            lines.append(f"{pad}  {event['at']}: {event['event']}{said}")
        for cited in v.get("cites", []):
            lines.append(f"{pad}  cites:")
            self._why(cited, depth + 2, seen, lines)

    def invalidate(self, text: str, reason: str, *, by: str = "") -> None:
        """Mark ``kind/key`` as no longer believed (it stays, with why); recall skips it from now on."""
        kind, key = split_key(text)
        self.store.invalidate((ROOT, kind), key, reason, by=by)

    def close(self) -> None:
        self.store.close()

    @staticmethod
    def _recollection(item: Item, lat: float, lon: float) -> Recollection:
        v = item.value
        where = v.get("where") if isinstance(v.get("where"), dict) else None
        return Recollection(
            key=item.key,
            kind=v.get("kind", item.namespace[-1]),
            text=str(v.get("text", "")),
            severity=v.get("severity"),
            lat=where["lat"] if where else None,
            lon=where["lon"] if where else None,
            distance_m=distance_m(lat, lon, where["lat"], where["lon"]) if where else None,
            provenance=Provenance.model_validate(v.get("provenance", {})),
        )


def cited(text: str) -> list[str]:
    """The ``kind/key`` of every memory a text cites as ``[memory kind/key]``.

    >>> cited("Busy before [memory incident/R1:8], and [memory casualty/R1:20].")
    ['incident/R1:8', 'casualty/R1:20']
    """
    return [f"{k}/{key}" for k, key in CITATION.findall(text)]


__all__ = ["ROOT", "FleetMemory", "cited", "split_key"]
