"""Safe expressions for missions: preconditions, conditions and ``${...}`` argument templates.

An expression is one Python-syntax expression, parsed with :mod:`ast`, checked against a whitelist and run by a
small tree-walking interpreter; it is never handed to ``eval``. The language:

* literals: numbers, strings, ``True``/``False``/``None`` (also ``true``/``false``/``null``), lists, tuples, dicts;
* names read from the scope (``params``, ``steps``, ``vehicle``, ``world``, ``event``, step ids, ...);
* ``a.b`` (a dict key, or a field of a pydantic model, dataclass, named tuple or ``SimpleNamespace``), ``a[0]``,
  ``a["k"]``, ``a[1:3]``; names and fields starting with ``_`` are refused;
* comparisons (chained too, ``in``/``not in``), ``and``/``or``/``not``, ``+ - * / // % **``, unary ``-``/``+`` and
  ``x if c else y``;
* calls to :data:`FUNCTIONS` only (defined in :mod:`.functions`): ``min max abs len round sum any all``,
  ``distance_m(a, b)`` and
  ``count(items, **filters)`` and ``find(world, relation=..., **filters)`` (filters ``field=value`` or
  ``field__gte=value`` and the like; ``class_=``/``cls=`` filter on the ``class`` field). An unknown operator
  (``field__ge``), or a field World Model objects lack where the items are theirs, is refused when parsed.

Syntax errors and refused constructs raise :class:`ExpressionError` from :meth:`Expression.parse`, unknown names
from :meth:`Expression.check_names`, so a bad mission fails when it is loaded. Evaluation failures raise
:class:`ExpressionError` naming the failing part. ``**`` and string repetition are bounded; expressions are at most
1,000 characters and 50 levels deep. ``${...}`` argument templates are in :mod:`.templates`.

>>> Expression.parse("steps.scan.persons >= 2 and vehicle.battery_pct > 30").evaluate(
...     {"steps": {"scan": {"persons": 3}}, "vehicle": {"battery_pct": 55}})
True
"""

from __future__ import annotations

import ast
import difflib
import functools
import math
import operator
from collections.abc import Callable, Iterable, Mapping
from typing import Any

from agentic_core.contracts.errors import InputError
from agentic_core.contracts.world_model import WorldObject

from .functions import ARITY as _ARITY
from .functions import (
    FUNCTIONS,
    count,
    distance_m,
    filter_keys,
    filter_operator_problem,
    find,
    readable_fields,
    split_filter,
)
from .functions import MISSING as _MISSING
from .functions import TAKES_FILTERS as _TAKES_FILTERS
from .functions import get_field as _get_field
from .functions import is_record as _is_record
from .functions import record_fields as _record_fields

__all__ = ["FUNCTIONS", "Expression", "ExpressionError", "count", "distance_m", "find"]

MAX_SOURCE_CHARS = 1000
MAX_DEPTH = 50
MAX_POWER_BITS = 10_000
MAX_REPEAT_CHARS = 10_000
_ALIASES: dict[str, Any] = {"true": True, "false": False, "null": None}


class ExpressionError(InputError):
    """A bad expression: ``source`` (its text), ``col`` (0-based column of the fault, or None) and ``message``
    (the one-line text of ``str(error)``, which quotes the expression)."""

    def __init__(self, message: str, source: str = "", col: int | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.source = source
        self.col = col


def _quote(text: str, limit: int = 80) -> str:
    return repr(text if len(text) <= limit else text[: limit - 1] + "…")


def _short(value: Any) -> str:
    try:
        text = repr(value)
    except Exception:  # e.g. an int too long to print
        return f"<{type(value).__name__}>"
    return text if len(text) <= 40 else text[:39] + "…"


def _listing(names: Iterable[str], limit: int = 30) -> str:
    items = list(names)
    return (", ".join(items[:limit]) + (", …" if len(items) > limit else "")) if items else "none"


def _suggest(name: str, candidates: Iterable[Any]) -> str:
    match = difflib.get_close_matches(name, [c for c in candidates if isinstance(c, str)], n=1)
    return f"; did you mean {match[0]!r}?" if match else ""


def _no_field(obj: Any, name: str) -> str:
    if isinstance(obj, Mapping) or _is_record(obj):
        fields = _record_fields(obj)
        return f"no field {name!r} (fields: {_listing(fields)}{_suggest(name, fields)})"
    return f"a value of type {type(obj).__name__} has no fields (cannot read {name!r})"


_BINARY: dict[type[ast.operator], Callable[[Any, Any], Any]] = {
    ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
    ast.FloorDiv: operator.floordiv, ast.Mod: operator.mod, ast.Pow: operator.pow,
}  # fmt: skip
_UNARY: dict[type[ast.unaryop], Callable[[Any], Any]] = {
    ast.Not: operator.not_,
    ast.USub: operator.neg,
    ast.UAdd: operator.pos,
}
_COMPARE: dict[type[ast.cmpop], Callable[[Any, Any], Any]] = {
    ast.Eq: operator.eq, ast.NotEq: operator.ne, ast.Lt: operator.lt, ast.LtE: operator.le, ast.Gt: operator.gt,
    ast.GtE: operator.ge, ast.In: lambda a, b: a in b, ast.NotIn: lambda a, b: a not in b,
}  # fmt: skip
_PLAIN: tuple[type[ast.AST], ...] = (ast.Attribute, ast.BinOp, ast.UnaryOp, ast.Compare, ast.Dict, ast.BoolOp)
_PLAIN += (ast.IfExp, ast.Subscript, ast.Slice, ast.List, ast.Tuple)
_REFUSED = {
    ast.Lambda: "lambda", ast.NamedExpr: "':=' (walrus)", ast.JoinedStr: "an f-string", ast.Set: "a set (use a list)",
    ast.ListComp: "a comprehension", ast.SetComp: "a comprehension", ast.DictComp: "a comprehension",
    ast.GeneratorExp: "a comprehension", ast.Starred: "'*' unpacking", ast.Await: "await", ast.Yield: "yield",
}  # fmt: skip
_ALLOWED = (
    "allowed: literals, names, a.b, a[i], comparisons, and/or/not, + - * / // % **, x if c else y, "
    f"calls to {', '.join(FUNCTIONS)}"
)


# ---- parsing and checking ----


class Expression:
    """A parsed, whitelisted expression; build one with :meth:`parse`."""

    __slots__ = ("_fields", "_names", "_offset", "_roots", "_text", "_tree", "source")

    def __init__(self, source: str) -> None:
        self.source = source
        if len(source) > MAX_SOURCE_CHARS:
            raise ExpressionError(
                f"expression too long ({len(source)} characters, at most {MAX_SOURCE_CHARS}): {_quote(source)}", source
            )
        flat = source.replace("\r", " ").replace("\n", " ")  # YAML folding may leave line breaks; offsets unchanged
        self._text = flat.strip()
        self._offset = len(flat) - len(flat.lstrip())
        if not self._text:
            raise ExpressionError(f"empty expression {_quote(source)}", source, 0)
        try:
            self._tree = ast.parse(self._text, mode="eval")
        except SyntaxError as exc:
            why = " ".join(str(exc.msg).split())
            if not exc.offset:  # CPython gives no offset for an expression cut short
                col, where = self._offset + len(self._text), "at the end"
            else:
                col = min(len(source), self._offset + exc.offset - 1)
                where = f"at column {col}"
            raise ExpressionError(f"invalid syntax {where} of {_quote(source)}: {why}", source, col) from None
        except (ValueError, RecursionError, MemoryError) as exc:
            raise ExpressionError(f"cannot parse {_quote(source)}: {exc}", source) from None
        checker = _Checker(self)
        self._names = checker.run()
        # what validation asks of every expression, answered once here rather than by walking the tree again
        self._roots = frozenset(name for name, _ in self._names)
        self._fields = {root: frozenset(fields) for root, fields in checker.fields.items()}

    @classmethod
    def parse(cls, source: str) -> Expression:
        """Parse and check ``source``; ExpressionError (with ``col``) for bad syntax or a refused construct."""
        return _parse_cached(source) if cls is Expression else cls(source)

    @property
    def root_names(self) -> frozenset[str]:
        """The top-level names the expression reads (function names excluded)."""
        return self._roots

    def fields_of(self, root: str) -> frozenset[str]:
        """The fields read directly off a root name: ``{"alt"}`` for ``params.alt + 1`` and root ``params``."""
        return self._fields.get(root, _NO_FIELDS)

    def check_names(self, known: Iterable[str]) -> None:
        """Raise ExpressionError for the first name not in ``known``, suggesting the closest known one."""
        names = known if isinstance(known, tuple) else tuple(known)
        lookup = _name_set(names)
        for name, col in self._names:
            if name not in lookup:
                names = tuple(dict.fromkeys(names))
                hint = f"known: {_listing(names)}{_suggest(name, names)}"
                raise ExpressionError(f"unknown name {name!r} in {_quote(self.source)} ({hint})", self.source, col)

    def evaluate(self, scope: Mapping[str, Any]) -> Any:
        """Run the expression over ``scope``; any failure is an ExpressionError naming the failing part."""
        return _Evaluator(self, scope).eval(self._tree.body)

    def _col(self, node: ast.AST) -> int:
        """The 0-based column of ``node`` in ``source``."""
        prefix = self._text.encode()[: getattr(node, "col_offset", 0)]
        return self._offset + len(prefix.decode(errors="ignore"))

    def _fail(self, node: ast.AST, problem: str, hint: str = "") -> ExpressionError:
        """An ExpressionError at ``node``: 'problem at <part> in <expression> (hint)'."""
        part = ast.get_source_segment(self._text, node) or ast.unparse(node)
        where = "" if part == self._text else f" at {_quote(part, 60)}"
        tail = f" ({hint})" if hint else ""
        return ExpressionError(f"{problem}{where} in {_quote(self.source)}{tail}", self.source, self._col(node))

    def __repr__(self) -> str:
        return f"Expression({self.source!r})"

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Expression) and other.source == self.source

    def __hash__(self) -> int:
        return hash(self.source)


_NO_FIELDS: frozenset[str] = frozenset()
_OBJECT_FIELDS = frozenset(readable_fields(WorldObject))


class _Checker:
    """Walks the tree once: refuses what is not whitelisted, bounds the depth, collects root names and the
    fields read directly off a name (``params.alt``)."""

    def __init__(self, expr: Expression) -> None:
        self.expr = expr
        self.names: list[tuple[str, int]] = []
        self.fields: dict[str, set[str]] = {}  # root name -> the fields read off it

    def run(self) -> tuple[tuple[str, int], ...]:
        stack: list[tuple[ast.AST, int]] = [(self.expr._tree.body, 1)]
        while stack:
            node, depth = stack.pop()
            if depth > MAX_DEPTH:
                raise self.expr._fail(node, f"expression nested more than {MAX_DEPTH} levels deep")
            stack.extend((child, depth + 1) for child in self.children(node))
        return tuple(dict.fromkeys(sorted(self.names, key=lambda item: item[1])))

    def children(self, node: ast.AST) -> list[ast.AST]:
        fail = self.expr._fail
        if isinstance(node, ast.Constant):
            if not isinstance(node.value, bool | int | float | str | None):
                raise fail(node, f"{type(node.value).__name__} literals are not allowed", _ALLOWED)
        elif isinstance(node, ast.Name):
            if node.id.startswith("_"):
                raise fail(node, f"names starting with '_' are not allowed ({node.id!r})")
            if node.id not in _ALIASES:
                self.names.append((node.id, self.expr._col(node)))
        elif isinstance(node, ast.Attribute):
            if node.attr.startswith("_"):
                raise fail(node, f"fields starting with '_' are not allowed ({node.attr!r})")
            if isinstance(node.value, ast.Name):
                self.fields.setdefault(node.value.id, set()).add(node.attr)
        elif isinstance(node, ast.Call):
            return self.call(node)
        elif isinstance(node, ast.Dict) and None in node.keys:
            raise fail(node, "'**' unpacking is not allowed", _ALLOWED)
        elif isinstance(node, ast.Compare) and any(isinstance(op, ast.Is | ast.IsNot) for op in node.ops):
            raise fail(node, "'is' is not allowed", "use == or != instead")
        elif isinstance(node, ast.BinOp | ast.UnaryOp) and type(node.op) not in _BINARY | _UNARY:
            raise fail(node, f"the operator {type(node.op).__name__} is not allowed", _ALLOWED)
        elif not isinstance(node, _PLAIN):
            raise fail(node, f"{_REFUSED.get(type(node), type(node).__name__)} is not allowed", _ALLOWED)
        return [child for child in ast.iter_child_nodes(node) if isinstance(child, ast.expr)]

    def call(self, node: ast.Call) -> list[ast.AST]:
        fail = self.expr._fail
        if isinstance(node.func, ast.Attribute):
            raise fail(node, "method calls are not allowed", f"functions: {', '.join(FUNCTIONS)}")
        name = node.func.id if isinstance(node.func, ast.Name) else ""
        if name not in FUNCTIONS:
            hint = f"functions: {', '.join(FUNCTIONS)}{_suggest(name, FUNCTIONS)}"
            raise fail(node, f"unknown function {name or ast.unparse(node.func)!r}", hint)
        if any(kw.arg is None for kw in node.keywords) or (node.keywords and name not in _TAKES_FILTERS):
            raise fail(
                node, f"{name}() takes no keyword arguments" if name not in _TAKES_FILTERS else "'**' is not allowed"
            )
        low, high = _ARITY.get(name, (1, 1))
        if not low <= len(node.args) <= high:
            raise fail(
                node, f"{name}() takes {low if low == high else f'{low} or more'} argument(s), not {len(node.args)}"
            )
        for kw in node.keywords:
            self.filter(name, node, kw)
        return [*node.args, *(kw.value for kw in node.keywords)]

    def filter(self, function: str, call: ast.Call, kw: ast.keyword) -> None:
        """Refuse a filter of ``find``/``count`` with an unknown operator, or naming a field World Model objects
        do not have (when the items are World Model objects: ``find``'s, or ``count`` of ``find`` or
        ``world.objects``), so the condition cannot silently never hold."""
        name = str(kw.arg)
        if function == "find" and name == "relation":
            return
        problem = filter_operator_problem(name)
        if problem is not None:
            raise self.expr._fail(kw, problem)
        if not (function == "find" or _world_objects(call.args[0] if call.args else None)):
            return
        if not any(key in _OBJECT_FIELDS for key in filter_keys(name)):
            field = split_filter(name)[0]
            fields = readable_fields(WorldObject)
            hint = f"fields: {', '.join(fields)}{_suggest(filter_keys(name)[0], fields)}"
            raise self.expr._fail(kw, f"World Model objects have no field {field!r} (filter {name!r})", hint)


def _world_objects(node: ast.expr | None) -> bool:
    """Whether ``node`` is ``world.objects`` or a ``find(...)`` call: items known to be World Model objects."""
    if isinstance(node, ast.Attribute):
        return node.attr == "objects" and isinstance(node.value, ast.Name) and node.value.id == "world"
    return isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "find"


# ---- evaluation ----


def _check_binary(op: ast.operator, left: Any, right: Any) -> None:
    if isinstance(op, ast.Pow) and isinstance(left, int) and isinstance(right, int) and right > 0:
        if abs(left) > 1 and math.log2(abs(left)) * right > MAX_POWER_BITS:
            raise ValueError(f"result of ** too large (over {MAX_POWER_BITS} bits)")
    elif isinstance(op, ast.Mult) and any(isinstance(v, list | tuple | bytes) for v in (left, right)):
        raise TypeError("repeating a list or tuple with * is not allowed")
    elif isinstance(op, ast.Mult) and isinstance(left, str) != isinstance(right, str):
        text, times = (left, right) if isinstance(left, str) else (right, left)
        if isinstance(times, int) and len(text) * times > MAX_REPEAT_CHARS:
            raise ValueError(f"repeated string longer than {MAX_REPEAT_CHARS} characters")
    elif isinstance(op, ast.Mod) and not isinstance(left, int | float):
        raise TypeError(f"% needs numbers, not {type(left).__name__}")


def _describe(exc: Exception) -> str:
    if isinstance(exc, ZeroDivisionError):
        return "division by zero"
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if isinstance(exc, TypeError | ValueError) else f"{type(exc).__name__}: {text}"


class _Evaluator:
    def __init__(self, expr: Expression, scope: Mapping[str, Any]) -> None:
        self.expr = expr
        self.scope = scope

    def eval(self, node: ast.AST) -> Any:
        try:
            return getattr(self, f"_{type(node).__name__}")(node)
        except ExpressionError:
            raise
        except Exception as exc:  # anything raised by an operator, function or field is the expression's fault
            raise self.expr._fail(node, _describe(exc)) from exc

    def _Constant(self, node: ast.Constant) -> Any:
        return node.value

    def _Name(self, node: ast.Name) -> Any:
        if node.id in _ALIASES:
            return _ALIASES[node.id]
        if node.id not in self.scope:
            names = list(self.scope)
            raise self.expr._fail(
                node, f"unknown name {node.id!r}", f"available: {_listing(names)}{_suggest(node.id, names)}"
            )
        return self.scope[node.id]

    def _Attribute(self, node: ast.Attribute) -> Any:
        obj = self.eval(node.value)
        value = _get_field(obj, node.attr)
        if value is _MISSING:
            raise self.expr._fail(node, _no_field(obj, node.attr))
        return value

    def _Subscript(self, node: ast.Subscript) -> Any:
        obj, key = self.eval(node.value), self.eval(node.slice)
        if isinstance(key, str) and (isinstance(obj, Mapping) or _is_record(obj)):
            value = _get_field(obj, key)
            if value is _MISSING:
                raise self.expr._fail(node, _no_field(obj, key))
            return value
        if isinstance(obj, list | tuple | str) and isinstance(key, int) and not -len(obj) <= key < len(obj):
            raise self.expr._fail(node, f"index {key} out of range (length {len(obj)})")
        if isinstance(obj, Mapping) and key not in obj:
            raise self.expr._fail(node, f"no key {_short(key)} (keys: {_listing(_short(k) for k in obj)})")
        return obj[key]

    def _Slice(self, node: ast.Slice) -> slice:
        return slice(*(None if part is None else self.eval(part) for part in (node.lower, node.upper, node.step)))

    def _BinOp(self, node: ast.BinOp) -> Any:
        left, right = self.eval(node.left), self.eval(node.right)
        _check_binary(node.op, left, right)
        return _BINARY[type(node.op)](left, right)

    def _UnaryOp(self, node: ast.UnaryOp) -> Any:
        return _UNARY[type(node.op)](self.eval(node.operand))

    def _BoolOp(self, node: ast.BoolOp) -> Any:
        value: Any = None
        for operand in node.values:
            value = self.eval(operand)
            if bool(value) == isinstance(node.op, ast.Or):
                return value
        return value

    def _Compare(self, node: ast.Compare) -> Any:
        left, result = self.eval(node.left), True
        for op, comparator in zip(node.ops, node.comparators, strict=True):
            right = self.eval(comparator)
            result = _COMPARE[type(op)](left, right)
            if not result:
                return result
            left = right
        return result

    def _IfExp(self, node: ast.IfExp) -> Any:
        return self.eval(node.body) if self.eval(node.test) else self.eval(node.orelse)

    def _Call(self, node: ast.Call) -> Any:
        assert isinstance(node.func, ast.Name)
        args = [self.eval(arg) for arg in node.args]
        kwargs = {kw.arg: self.eval(kw.value) for kw in node.keywords if kw.arg is not None}
        return FUNCTIONS[node.func.id](*args, **kwargs)

    def _List(self, node: ast.List) -> list[Any]:
        return [self.eval(item) for item in node.elts]

    def _Tuple(self, node: ast.Tuple) -> tuple[Any, ...]:
        return tuple(self.eval(item) for item in node.elts)

    def _Dict(self, node: ast.Dict) -> dict[Any, Any]:
        pairs = zip(node.keys, node.values, strict=True)
        return {self.eval(key): self.eval(value) for key, value in pairs if key is not None}


@functools.lru_cache(maxsize=4096)
def _parse_cached(source: str) -> Expression:
    """Expressions are immutable once parsed: the same text (a template used by many steps) parses once."""
    return Expression(source)


@functools.lru_cache(maxsize=16)
def _name_set(names: tuple[str, ...]) -> frozenset[str]:
    return frozenset(names)
