"""A numpy pre-filter for the numeric and place conditions of a search filter, so that a selective filter over
tens of thousands of memories does not parse every one of them.

For each field a filter compares with numbers (``$gt $gte $lt $lte``) or ``$near``, the ids and values of every
item are read once (``json_extract``) and held as arrays until the next write. :meth:`Prefilter.allowed` returns
the ids that may pass; the exact check (:func:`~agentic_core.memory.filters.accepts`) still runs on each of them.
A value stored as text is kept as a candidate (the exact check reads ``"5"`` as 5); a missing one is not.
"""

from __future__ import annotations

import math
import sqlite3
import threading
from collections.abc import Mapping
from typing import Any

import numpy as np

from .namespaces import decode, under

METRES_PER_DEG_LAT = 110_574.0  # the least of the ellipsoid's: a box from it is never smaller than the circle
NUMERIC = ("$gt", "$gte", "$lt", "$lte")


def _path(parts: list[str]) -> str:
    return "$" + "".join(f'."{p}"' for p in parts)


class Prefilter:
    """Arrays per JSON path (``ids``, ``values``, ``is_text``), rebuilt lazily after :meth:`stale`."""

    def __init__(self, conn: sqlite3.Connection, lock: threading.RLock) -> None:
        self.conn = conn
        self.lock = lock
        self._columns: dict[str, tuple[Any, Any, Any]] = {}
        self._ns: tuple[Any, list[tuple[str, ...]]] | None = None

    def stale(self) -> None:
        self._columns.clear()
        self._ns = None

    def _column(self, path: str) -> tuple[Any, Any, Any]:
        if path not in self._columns:
            rows = self.conn.execute(
                "SELECT id, json_extract(value, ?), json_type(value, ?) FROM store_items ORDER BY id", (path, path)
            ).fetchall()
            ids = np.fromiter((r[0] for r in rows), dtype=np.int64, count=len(rows))
            values = np.fromiter(
                (float(r[1]) if r[2] in ("integer", "real") else math.nan for r in rows), dtype=np.float64,
                count=len(rows),
            )  # fmt: skip
            is_text = np.fromiter((r[2] == "text" for r in rows), dtype=bool, count=len(rows))
            self._columns[path] = (ids, values, is_text)
        return self._columns[path]

    def _namespaces(self, prefix: tuple[str, ...]) -> Any:
        if self._ns is None:
            rows = self.conn.execute("SELECT ns FROM store_items ORDER BY id").fetchall()
            codes: dict[str, int] = {}
            arr = np.fromiter((codes.setdefault(r[0], len(codes)) for r in rows), dtype=np.int64, count=len(rows))
            self._ns = (arr, [decode(ns) for ns in codes])
        arr, names = self._ns
        inside = [c for c, ns in enumerate(names) if under(ns, prefix)]
        return np.isin(arr, inside)

    def allowed(self, filter: Mapping[str, Any] | None, prefix: tuple[str, ...]) -> Any | None:
        """Sorted ids that may pass ``filter`` under ``prefix``; None when the filter has nothing to pre-filter."""
        conditions = list(_conditions(filter or {}, []))
        if not conditions:
            return None
        with self.lock:
            keep: Any = None
            ids: Any = None
            for parts, op, arg in conditions:
                if op == "$near":
                    mask, ids = self._near(parts, arg)
                else:
                    ids, values, is_text = self._column(_path(parts))
                    with np.errstate(invalid="ignore"):
                        hit = {"$gt": values > arg, "$gte": values >= arg, "$lt": values < arg, "$lte": values <= arg}
                    mask = hit[op] | is_text
                keep = mask if keep is None else keep & mask
            if prefix:
                keep = keep & self._namespaces(prefix)
            return ids[keep]

    def _near(self, parts: list[str], arg: Mapping[str, Any]) -> tuple[Any, Any]:
        ids, lat, lat_text = self._column(_path([*parts, "lat"]))
        _, lon, lon_text = self._column(_path([*parts, "lon"]))
        clat, clon, r = float(arg["lat"]), float(arg["lon"]), float(arg["within_m"])
        dlat = r / METRES_PER_DEG_LAT
        dlon = r / (METRES_PER_DEG_LAT * max(math.cos(math.radians(min(89.0, abs(clat) + dlat))), 1e-6))
        with np.errstate(invalid="ignore"):
            box = (np.abs(lat - clat) <= dlat * 1.01) & (np.abs(lon - clon) <= dlon * 1.01)
        return box | lat_text | lon_text, ids


def _conditions(node: Mapping[str, Any], parts: list[str]) -> Any:
    """``(path parts, operator, argument)`` for every numeric or place condition, nested objects included."""
    for key, wanted in node.items():
        if not isinstance(key, str) or key.startswith("$") or not isinstance(wanted, Mapping):
            continue
        if any(isinstance(k, str) and k.startswith("$") for k in wanted):
            for op, arg in wanted.items():
                if op == "$near":
                    yield [*parts, key], op, arg
                elif op in NUMERIC and isinstance(arg, int | float) and not isinstance(arg, bool):
                    yield [*parts, key], op, float(arg)
        else:
            yield from _conditions(wanted, [*parts, key])


__all__ = ["Prefilter"]
