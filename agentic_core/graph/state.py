"""The state schema: which keys exist, how writes to each merge (reducer or last value), and typed validation.

A state is a ``TypedDict`` or a pydantic model. A key annotated ``Annotated[T, reducer]`` (a binary function)
merges writes through the reducer; any other key keeps the last value written. Every update a node returns is
checked against the declared types, so a wrong type fails at the node that wrote it, not three nodes later.
"""

from __future__ import annotations

import inspect
import typing
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Annotated, Any, get_args, get_origin, get_type_hints

from .errors import GraphError, InvalidUpdateError, StateTypeError

if TYPE_CHECKING:
    from pydantic import TypeAdapter

MISSING: Any = object()


def _is_binop(obj: Any) -> bool:
    """True for a callable taking two positional arguments, the shape of a reducer."""
    if not callable(obj) or isinstance(obj, type):
        return False
    try:
        params = list(inspect.signature(obj).parameters.values())
    except (TypeError, ValueError):  # builtins such as operator.add have no signature on some versions
        return True
    positional = [p for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    return len(positional) >= 2 or any(p.kind == p.VAR_POSITIONAL for p in params)


def _type_name(tp: Any) -> str:
    if isinstance(tp, type):
        return tp.__name__
    return str(tp).replace("typing.", "")


@dataclass(slots=True)
class KeySpec:
    """One state key: its declared type, its reducer (None for last-value) and its validator."""

    name: str
    type_: Any
    reducer: Callable[[Any, Any], Any] | None
    adapter: TypeAdapter[Any] | None
    default: Any = MISSING
    initial: Any = MISSING  # what a reducer key starts from: the empty value of its type where there is one

    @property
    def type_name(self) -> str:
        return _type_name(self.type_)


def _split_annotated(annotation: Any) -> tuple[Any, Callable[[Any, Any], Any] | None]:
    if get_origin(annotation) is Annotated:
        base, *meta = get_args(annotation)
        if meta and _is_binop(meta[-1]):
            return base, meta[-1]
        return base, None
    return annotation, None


def _empty_value(tp: Any) -> Any:
    """``list()``, ``dict()``, ``int()``... for a reducer key's type, so the first write goes through the reducer."""
    origin = get_origin(tp) or tp
    if origin in (list, dict, set, tuple, int, float, str, frozenset):
        return origin()
    return MISSING


class StateSchema:
    """Introspects a TypedDict or pydantic model once and answers for it at run time."""

    def __init__(self, schema: Any) -> None:
        from pydantic import BaseModel, TypeAdapter  # on first use: pydantic is most of the import time

        self.schema = schema
        self.is_model = isinstance(schema, type) and issubclass(schema, BaseModel)
        if not self.is_model and not typing.is_typeddict(schema):
            raise GraphError(
                f"StateGraph needs a TypedDict or a pydantic BaseModel as its state schema, got {schema!r}"
            )
        try:
            hints = get_type_hints(schema, include_extras=True)
        except NameError as exc:
            raise GraphError(f"cannot resolve the annotations of state schema {schema.__name__}: {exc}") from exc
        self.keys: dict[str, KeySpec] = {}
        model_fields = schema.model_fields if self.is_model else {}
        for name, annotation in hints.items():
            if self.is_model and name not in model_fields:
                continue  # ClassVar and private attributes
            base, reducer = _split_annotated(annotation)
            adapter = None if base is Any else TypeAdapter(base)
            default = MISSING
            if self.is_model:
                field = model_fields[name]
                if not field.is_required():
                    default = field.get_default(call_default_factory=True)
            self.keys[name] = KeySpec(name, base, reducer, adapter, default, _empty_value(base) if reducer else MISSING)

    @property
    def name(self) -> str:
        return str(getattr(self.schema, "__name__", self.schema))

    def spec(self, node: str, key: str) -> KeySpec:
        try:
            return self.keys[key]
        except KeyError:
            known = ", ".join(sorted(self.keys)) or "(none)"
            raise InvalidUpdateError(
                f"node {node!r} wrote key {key!r}, which is not in state schema {self.name} "
                f"(known keys: {known}); add it to the schema or stop writing it"
            ) from None

    def check_value(self, node: str, spec: KeySpec, value: Any) -> Any:
        """Validate one written value against its key's declared type; return the value to store."""
        if spec.adapter is None:
            return value
        try:
            return spec.adapter.validate_python(value, strict=True)
        except Exception as strict_error:
            from pydantic import ValidationError

            if not isinstance(strict_error, ValidationError):
                raise
            if isinstance(value, Mapping | list | tuple):
                # Containers may be coerced structurally (a dict into a nested model); scalars never are.
                try:
                    return spec.adapter.validate_python(value)
                except ValidationError:
                    pass
            first = strict_error.errors()[0]
            where = ".".join(str(p) for p in first.get("loc", ()))
            detail = first.get("msg", "")
            if where:
                detail = f"at {where}: {detail}"
            raise StateTypeError(node, spec.name, spec.type_name, type(value).__name__, detail) from None

    def check_write(self, node: str, key: str, value: Any, current: Any = MISSING) -> Any:
        """Validate a write. For a reducer key a value that is not itself of the key's type (one message for a
        list of messages) is accepted when the reducer turns it into one."""
        spec = self.spec(node, key)
        if spec.reducer is None or spec.adapter is None:
            return self.check_value(node, spec, value)
        try:
            return self.check_value(node, spec, value)
        except StateTypeError as first:
            base = current if current is not MISSING else spec.initial
            if base is MISSING:
                raise
            try:
                spec.adapter.validate_python(spec.reducer(base, value))
            except Exception:
                raise first from None
            return value

    def update_to_dict(self, node: str, update: Any) -> dict[str, Any]:
        """Normalise what a node returned (mapping, model instance or None) into a dict of writes."""
        if update is None:
            return {}
        if isinstance(update, Mapping):
            return dict(update)
        from pydantic import BaseModel

        if isinstance(update, BaseModel):
            return {k: getattr(update, k) for k in update.model_fields_set}
        raise InvalidUpdateError(
            f"node {node!r} returned {type(update).__name__}; a node must return a dict of state updates "
            f"(keys of {self.name}), a Command, or None"
        )

    def initial_values(self) -> dict[str, Any]:
        """A new thread's values: model defaults, and the empty value of each reducer key (as LangGraph)."""
        values = {k: s.initial for k, s in self.keys.items() if s.initial is not MISSING}
        values.update(self.defaults())
        return values

    def defaults(self) -> dict[str, Any]:
        return {k: s.default for k, s in self.keys.items() if s.default is not MISSING}

    def to_node_input(self, values: Mapping[str, Any]) -> Any:
        """The state as a node receives it: a dict for a TypedDict, a model instance for a model."""
        if self.is_model:
            merged = {**self.defaults(), **values}
            return self.schema.model_construct(**merged)
        return dict(values)

    def check_complete(self, node: str, values: Mapping[str, Any]) -> None:
        """For model states, all required fields must have a value before the first node runs."""
        if not self.is_model:
            return
        missing = [k for k, s in self.keys.items() if s.default is MISSING and k not in values]
        if missing:
            raise InvalidUpdateError(
                f"{node}: state {self.name} is missing required field(s) {', '.join(missing)}; "
                f"give them in the input or give them defaults in the model"
            )
