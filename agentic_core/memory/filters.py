"""Search filters: exact values, nested objects, ``$eq $ne $gt $gte $lt $lte`` (LangGraph's), and ours for place
and time: ``$near`` (within a distance of a point) and :func:`within_last` (a ``$gte`` on epoch seconds).

>>> value = {"kind": "casualty", "where": {"lat": 21.4225, "lon": 39.8262}, "t": 100.0}
>>> accepts({"kind": "casualty", "t": {"$gte": 50}}, value)
True
>>> accepts({"where": near(21.4225, 39.8282, 100)}, value)  # 207 m east: outside 100 m
False
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any

from agentic_core.contracts.errors import InputError
from agentic_core.contracts.geodesy import distance_m

OPERATORS = ("$eq", "$ne", "$gt", "$gte", "$lt", "$lte", "$near")


def near(lat: float, lon: float, within_m: float) -> dict[str, Any]:
    """A filter on a ``{"lat", "lon"}`` field: within ``within_m`` metres (the project's ellipsoid) of ``lat, lon``.

    >>> near(21.42, 39.82, 200)
    {'$near': {'lat': 21.42, 'lon': 39.82, 'within_m': 200}}
    """
    return {"$near": {"lat": lat, "lon": lon, "within_m": within_m}}


def within_last(seconds: float, *, now: float | None = None) -> dict[str, Any]:
    """A filter on an epoch-seconds field: no older than ``seconds`` before ``now`` (the wall clock).

    >>> within_last(3600, now=10_000.0)
    {'$gte': 6400.0}
    """
    return {"$gte": (time.time() if now is None else now) - seconds}


def accepts(filter: Mapping[str, Any] | None, value: Mapping[str, Any]) -> bool:
    """Whether ``value`` passes every condition of ``filter`` (no filter passes everything)."""
    return not filter or all(_matches(value.get(k), f) for k, f in filter.items())


def check(filter: object) -> dict[str, Any] | None:
    """The filter, or :class:`InputError` naming what is wrong with it (before any item is read)."""
    if filter is None:
        return None
    if not isinstance(filter, Mapping):
        raise InputError(f"a search filter is a mapping of field to value, got {type(filter).__name__}")
    _check_operators(filter, "filter")
    return dict(filter)


def _check_operators(node: Mapping[str, Any], where: str) -> None:
    for k, v in node.items():
        if isinstance(k, str) and k.startswith("$"):
            if k not in OPERATORS:
                raise InputError(f"{where}: unknown operator {k!r} (known: {', '.join(OPERATORS)})")
            if k == "$near" and not (isinstance(v, Mapping) and {"lat", "lon", "within_m"} <= set(v)):
                raise InputError(f"{where}: $near needs lat, lon and within_m")
        elif isinstance(v, Mapping):
            _check_operators(v, f"{where}.{k}")


def _matches(item: Any, wanted: Any) -> bool:
    if isinstance(wanted, Mapping):
        if any(isinstance(k, str) and k.startswith("$") for k in wanted):
            return all(_operator(item, op, arg) for op, arg in wanted.items())
        return isinstance(item, Mapping) and all(_matches(item.get(k), v) for k, v in wanted.items())
    if isinstance(wanted, list | tuple):
        return (
            isinstance(item, list | tuple)
            and len(item) == len(wanted)
            and all(_matches(i, w) for i, w in zip(item, wanted, strict=True))
        )
    return bool(item == wanted)


def _number(x: Any) -> float | None:
    if isinstance(x, bool) or x is None:
        return None
    try:
        return float(x)
    except (TypeError, ValueError):
        return None


def _operator(item: Any, op: str, arg: Any) -> bool:
    if op == "$eq":
        return bool(item == arg)
    if op == "$ne":
        return bool(item != arg)
    if op == "$near":
        if not isinstance(item, Mapping):
            return False
        lat, lon = _number(item.get("lat")), _number(item.get("lon"))
        if lat is None or lon is None:
            return False
        return distance_m(lat, lon, float(arg["lat"]), float(arg["lon"])) <= float(arg["within_m"])
    a, b = _number(item), _number(arg)
    if a is None or b is None:
        return False
    return {"$gt": a > b, "$gte": a >= b, "$lt": a < b, "$lte": a <= b}[op]
