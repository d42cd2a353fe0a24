"""What mission expressions may call and read: the whitelisted pure functions and field access.

Field access reads a mapping's keys, or the public, non-method fields of a record (pydantic model, dataclass,
named tuple, ``SimpleNamespace``, date or time); nothing else, so an expression cannot walk into an object's
internals. The functions are pure and bounded.
"""

from __future__ import annotations

import dataclasses
import datetime
import difflib
import keyword
import math
import operator
from collections.abc import Callable, Iterable, Mapping
from types import MappingProxyType, SimpleNamespace
from typing import Any

from agentic_core.contracts import geodesy
from agentic_core.contracts.world_model import WorldObject

MISSING: Any = object()
"""What :func:`get_field` returns for a field that is not there."""


# ---- field access on dicts and records ----


def is_record(obj: Any) -> bool:
    """Objects whose public attributes may be read: pydantic models, dataclasses, named tuples, namespaces, dates."""
    return (
        (dataclasses.is_dataclass(obj) and not isinstance(obj, type))
        or isinstance(getattr(type(obj), "model_fields", None), Mapping)
        or (isinstance(obj, tuple) and hasattr(type(obj), "_fields"))
        or isinstance(obj, SimpleNamespace | datetime.date | datetime.time | datetime.timedelta)
    )


def record_fields(obj: Any) -> list[str]:
    if isinstance(obj, Mapping):
        return [key for key in obj if isinstance(key, str)]
    if dataclasses.is_dataclass(obj):
        return [field.name for field in dataclasses.fields(obj)]
    if isinstance(getattr(type(obj), "model_fields", None), Mapping):
        return list(type(obj).model_fields)
    names: Iterable[str] = getattr(obj, "_fields", None) or getattr(obj, "__dict__", None) or ()
    return [name for name in names if not name.startswith("_")]


_DYNAMIC: Any = object()
_RESOLVED: dict[tuple[type, str], Any] = {}
"""(type, name) -> the attribute holding that field for every instance of a type whose fields are fixed (pydantic
models without extras, dataclasses), None when it has no such field, or ``_DYNAMIC`` to look each time: expressions
read the same fields of thousands of world-model objects per evaluation."""


def _static_attribute(cls: type, name: str) -> Any:
    if name.startswith("_"):
        return None
    fields = getattr(cls, "model_fields", None)
    if isinstance(fields, Mapping):
        if getattr(cls, "model_config", {}).get("extra") == "allow":
            return _DYNAMIC  # extra fields live on the instance
        if name in fields or hasattr(cls, name):
            return name
        real = [field for field, info in fields.items() if getattr(info, "alias", None) == name]
        if real:
            return real[0]
        spelt = name + "_"
        return spelt if keyword.iskeyword(name) and (spelt in fields or hasattr(cls, spelt)) else None
    return _DYNAMIC  # dataclasses, namespaces and the like may carry attributes of their own


def get_field(obj: Any, name: str) -> Any:
    """``obj[name]`` for a mapping, the public non-method attribute (or pydantic alias) for a record, else MISSING."""
    if isinstance(obj, Mapping):
        return obj.get(name, MISSING)
    key = (type(obj), name)
    attribute = _RESOLVED.get(key)
    if attribute is None and key not in _RESOLVED:
        attribute = _RESOLVED[key] = _static_attribute(type(obj), name)
    if attribute is None:
        return MISSING
    if attribute is not _DYNAMIC:
        value = getattr(obj, attribute, MISSING)
        return MISSING if callable(value) else value
    if name.startswith("_") or not is_record(obj):
        return MISSING
    value = getattr(obj, name, MISSING)
    if value is MISSING:
        fields = getattr(type(obj), "model_fields", {})
        real = [field for field, info in fields.items() if getattr(info, "alias", None) == name]
        value = getattr(obj, real[0] if real else name + "_" if keyword.iskeyword(name) else name, MISSING)
    return MISSING if callable(value) else value  # methods are not fields


# ---- the whitelisted functions ----


def _number(value: Any, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise TypeError(f"{what} must be a number, not {type(value).__name__}")
    return float(value)


def _pair(position: Any, keys: tuple[tuple[str, str], ...]) -> tuple[float, float] | None:
    for first, second in keys:
        a, b = get_field(position, first), get_field(position, second)
        if a is not MISSING and b is not MISSING:
            return _number(a, first), _number(b, second)
    return None


def _geodesic_m(a: tuple[float, float], b: tuple[float, float]) -> float:
    if not (abs(a[0]) <= 90 and abs(b[0]) <= 90):
        raise ValueError("latitude must be between -90 and 90 degrees")
    return geodesy.distance_m(a[0], a[1], b[0], b[1])


def distance_m(a: Any, b: Any) -> float:
    """Horizontal distance in metres between two positions (dicts or records). Both with ``lat``/``lon`` (or
    ``latitude``/``longitude``): the WGS-84 ellipsoid's shortest distance; else both with ``north``/``east`` (or
    ``north_m``/``east_m``, local NED): Euclidean. One of each is refused."""
    geo = _pair(a, (("lat", "lon"), ("latitude", "longitude"))), _pair(b, (("lat", "lon"), ("latitude", "longitude")))
    if geo[0] is not None and geo[1] is not None:
        return _geodesic_m(geo[0], geo[1])
    ned = _pair(a, (("north", "east"), ("north_m", "east_m"))), _pair(b, (("north", "east"), ("north_m", "east_m")))
    if ned[0] is not None and ned[1] is not None:
        return math.hypot(ned[0][0] - ned[1][0], ned[0][1] - ned[1][1])
    for i, which in enumerate(("first", "second")):
        if geo[i] is None and ned[i] is None:
            raise ValueError(
                f"the {which} position has neither lat/lon (latitude/longitude) nor north/east (north_m/east_m)"
            )
    raise ValueError("cannot measure between a lat/lon position and a local north/east one")


def _filter_keys(name: str) -> tuple[str, ...]:
    if name == "cls" or (name.endswith("_") and keyword.iskeyword(name[:-1])):
        return (name, "class") if name == "cls" else (name[:-1], name)
    return (name,)


_LOOKUPS: dict[str, Callable[[Any, Any], bool]] = {
    "eq": operator.eq,
    "ne": operator.ne,
    "gt": operator.gt,
    "gte": operator.ge,
    "lt": operator.lt,
    "lte": operator.le,
    "in": lambda value, options: value in options,
}


FILTER_OPERATORS = tuple(_LOOKUPS)
"""The operators a filter name may end with (``field__op``); a name without one compares with ``==``."""


def split_filter(name: str) -> tuple[str, str | None]:
    """``stationary_s__gte`` -> ``('stationary_s', 'gte')``, ``class_`` -> ``('class_', None)``. The part after a
    name's last ``__`` is its operator, whatever it says: a misspelt one is an error, never part of the field."""
    field, sep, op = name.rpartition("__")
    return (field, op) if sep and field else (name, None)


def filter_operator_problem(name: str) -> str | None:
    """Why the filter ``name`` has no valid operator (a did-you-mean among :data:`FILTER_OPERATORS`), or None."""
    field, op = split_filter(name)
    if op is None or op in _LOOKUPS:
        return None
    close = difflib.get_close_matches(op, FILTER_OPERATORS, n=1, cutoff=0.5)
    hint = f"; did you mean '{field}__{close[0]}'?" if close else ""
    return f"unknown filter operator {op!r} in {name!r} (operators: {', '.join(FILTER_OPERATORS)}{hint})"


def filter_keys(name: str) -> tuple[str, ...]:
    """The fields a filter name reads, its operator left off (``class_`` reads ``class``, then ``class_``)."""
    return _filter_keys(split_filter(name)[0])


def _lookup(name: str) -> tuple[tuple[str, ...], Callable[[Any, Any], bool]]:
    """``stationary_s__gte`` -> (the field's keys, >=); a plain name compares with ==; a name ending with an
    unknown operator (``stationary_s__ge``) is a ValueError."""
    problem = filter_operator_problem(name)
    if problem is not None:
        raise ValueError(problem)
    field, op = split_filter(name)
    return _filter_keys(field), _LOOKUPS[op or "eq"]


def _matches(item: Any, keys: tuple[str, ...], test: Callable[[Any, Any], bool], wanted: Any) -> bool:
    for key in keys:
        value = get_field(item, key)
        if value is not MISSING:
            try:
                return bool(test(value, wanted))
            except TypeError:  # None >= 10 and the like: not a match
                return False
    if isinstance(item, WorldObject):  # its fields are the contract's: one it lacks is misspelt
        known = readable_fields(type(item))
        close = difflib.get_close_matches(keys[0], known, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        raise ValueError(f"a {type(item).__name__} has no field {keys[0]!r} (fields: {', '.join(known)}{hint})")
    return False  # a mapping without that key: not a match


def _select(items: Iterable[Any], filters: Mapping[str, Any]) -> list[Any]:
    wanted = [(*_lookup(name), value) for name, value in filters.items()]
    return [item for item in items if all(_matches(item, keys, test, value) for keys, test, value in wanted)]


def readable_fields(cls: type) -> list[str]:
    """The fields an expression may read of a pydantic model class: its fields, their aliases, its properties."""
    fields: Mapping[str, Any] = getattr(cls, "model_fields", {})
    names = [alias for info in fields.values() if isinstance(alias := getattr(info, "alias", None), str)]
    names += [name for name in fields if name not in names]
    for klass in cls.__mro__:
        if not klass.__module__.startswith("pydantic"):  # BaseModel's own properties are not the record's fields
            names += [n for n, v in vars(klass).items() if not n.startswith("_") and isinstance(v, property)]
    return list(dict.fromkeys(names))


def count(items: Iterable[Any], **filters: Any) -> int:
    """How many items match every filter; ``count(items)`` is their number. A filter is ``field=value``, or
    ``field__op=value`` with op one of eq, ne, gt, gte, lt, lte, in (any other is a ValueError). ``class`` is a
    Python keyword, so filter on it with ``class_=`` (or ``cls=``). A World Model object without the field is an
    error (a misspelling); another item without it does not match."""
    return len(_select(items, filters))


def find(world: Any, relation: str | None = None, **filters: Any) -> list[Any]:
    """The world model's objects that match the filters (as :func:`count`), and with ``relation=`` only those that
    are the subject of such a relation: ``find(world, class_='person', stationary_s__gte=10,
    relation='isolated_from')``. An empty list is false, so it reads as a condition; a trigger's event is the
    first object found."""
    objects = get_field(world, "objects")
    candidates = [] if objects is MISSING or objects is None else objects
    if relation is not None:  # the relation first: it leaves few objects for the filters
        relations = get_field(world, "relations")
        subjects = {
            get_field(r, "subj")
            for r in ([] if relations is MISSING or relations is None else relations)
            if get_field(r, "pred") == relation
        }
        candidates = [o for o in candidates if get_field(o, "id") in subjects]
    return _select(candidates, filters)


def _round(number: Any, ndigits: int | None = None) -> Any:
    if ndigits is not None and abs(ndigits) > 100:
        raise ValueError("round() takes at most 100 digits")
    return round(number, ndigits)


_FUNCTIONS: dict[str, Callable[..., Any]] = {"min": min, "max": max, "abs": abs, "len": len, "round": _round}
_FUNCTIONS |= {"sum": sum, "any": any, "all": all, "distance_m": distance_m, "count": count, "find": find}
TAKES_FILTERS = frozenset({"count", "find"})
FUNCTIONS: Mapping[str, Callable[..., Any]] = MappingProxyType(_FUNCTIONS)
ARITY = {"min": (1, 99), "max": (1, 99), "round": (1, 2), "distance_m": (2, 2)}  # the others take exactly one
