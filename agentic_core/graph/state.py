"""The state schema: which keys exist, how writes to each merge (reducer or last value), and typed validation.

A state is a ``TypedDict`` or a pydantic model. A key annotated ``Annotated[T, reducer]`` (a binary function)
merges writes through the reducer; any other key keeps the last value written. Every update a node returns is
checked against the declared types, so a wrong type fails at the node that wrote it, not three nodes later.
"""

from __future__ import annotations

import copy
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
    default: Any = MISSING  # a model field's default; copied for every new thread
    empty: type | None = None  # for a reducer key: the type whose empty value it starts from (list, dict, ...)

    @property
    def type_name(self) -> str:
        return _type_name(self.type_)

    def initial(self) -> Any:
        """A fresh starting value for a reducer key (a new list each time), or MISSING."""
        return self.empty() if self.empty is not None else MISSING


_REQUIRED_WRAPPERS = (
    (typing.Required, typing.NotRequired, typing.ReadOnly)
    if hasattr(typing, "ReadOnly")
    else (
        typing.Required,
        typing.NotRequired,
    )
)


def _split_annotated(annotation: Any) -> tuple[Any, Callable[[Any, Any], Any] | None]:
    while get_origin(annotation) in _REQUIRED_WRAPPERS:  # TypedDict's Required[...] / NotRequired[...]
        annotation = get_args(annotation)[0]
    if get_origin(annotation) is Annotated:
        base, *meta = get_args(annotation)
        if meta and _is_binop(meta[-1]):
            rest = [m for m in meta[:-1]]
            return (Annotated[(base, *rest)] if rest else base), meta[-1]
        return annotation, None
    return annotation, None


def _empty_type(tp: Any) -> type | None:
    """``list``, ``dict``, ``int``... for a reducer key's type, so the first write goes through the reducer."""
    origin = get_origin(tp) or tp
    if get_origin(tp) is Annotated:
        origin = get_origin(get_args(tp)[0]) or get_args(tp)[0]
    if origin in (list, dict, set, tuple, int, float, str, frozenset):
        return origin  # type: ignore[no-any-return]
    return None


def _adapter(base: Any) -> TypeAdapter[Any] | None:
    """A validator for a TypedDict key's type; plain classes pydantic does not know are checked by isinstance."""
    from pydantic import ConfigDict, TypeAdapter

    if base is Any:
        return None
    try:
        return TypeAdapter(base)
    except Exception:
        return TypeAdapter(base, config=ConfigDict(arbitrary_types_allowed=True))


def _is_typeddict(schema: Any) -> bool:
    """A ``typing`` or a ``typing_extensions`` TypedDict (before Python 3.12 they are different classes)."""
    if typing.is_typeddict(schema):
        return True
    import typing_extensions  # a dependency of pydantic

    return typing_extensions.is_typeddict(schema)


class StateSchema:
    """Introspects a TypedDict or pydantic model once and answers for it at run time."""

    def __init__(self, schema: Any) -> None:
        from pydantic import BaseModel  # on first use: pydantic is most of the import time

        self.schema = schema
        self.is_model = isinstance(schema, type) and issubclass(schema, BaseModel)
        if not self.is_model and not _is_typeddict(schema):
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
            default = MISSING
            if self.is_model:
                field = model_fields[name]
                if not field.is_required():
                    default = field.get_default(call_default_factory=True)
                adapter = None  # model fields are validated by pydantic's assignment validation (see check_value)
            else:
                try:
                    adapter = _adapter(base)
                except Exception as exc:
                    msg = f"state key {name!r} of {self.name}: pydantic cannot validate {base!r}: {exc}"
                    raise GraphError(msg) from exc
            self.keys[name] = KeySpec(name, base, reducer, adapter, default, _empty_type(base) if reducer else None)

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

    def _validate(self, spec: KeySpec, value: Any, values: Mapping[str, Any], strict: bool) -> Any:
        if self.is_model:
            # Assignment validation runs the field's constraints and field validators, as setting it would.
            probe = self.schema.model_construct(**values)
            self.schema.__pydantic_validator__.validate_assignment(probe, spec.name, value, strict=strict)
            return getattr(probe, spec.name)
        assert spec.adapter is not None
        return spec.adapter.validate_python(value, strict=strict)

    def check_value(self, node: str, spec: KeySpec, value: Any, values: Mapping[str, Any]) -> Any:
        """Validate one written value against its key's declared type; return the value to store."""
        if spec.adapter is None and not self.is_model:
            return value
        from pydantic import ValidationError

        try:
            return self._validate(spec, value, values, strict=True)
        except ValidationError as strict_error:
            error = strict_error
            if isinstance(value, Mapping | list | tuple):
                # Containers may be coerced structurally (a dict into a nested model); scalars never are.
                try:
                    return self._validate(spec, value, values, strict=False)
                except ValidationError as lax_error:
                    error = lax_error
            first = error.errors()[0]
            loc = [str(p) for p in first.get("loc", ())]
            if loc and loc[0] == spec.name:
                loc = loc[1:]
            detail = first.get("msg", "")
            if loc:
                detail = f"at {'.'.join(loc)}: {detail}"
            raise StateTypeError(node, spec.name, spec.type_name, type(value).__name__, detail) from None

    def check_write(self, node: str, key: str, value: Any, values: Mapping[str, Any]) -> Any:
        """Validate a write. For a reducer key a value that is not itself of the key's type (one message for a
        list of messages) is accepted when the reducer turns it into one."""
        spec = self.spec(node, key)
        if spec.reducer is None:
            return self.check_value(node, spec, value, values)
        if type(value) is tuple and spec.empty is list:
            try:  # ("assistant", "hi") is one item, not a list of two: hand the reducer the tuple as written
                self.check_value(node, spec, [value], values)
                return value
            except StateTypeError:
                pass
        try:
            return self.check_value(node, spec, value, values)
        except StateTypeError as first:
            if type(value) is not list and spec.empty is list:
                try:  # one item for a list key: validate it as the list it will be appended as
                    self.check_value(node, spec, [value], values)
                    return value
                except StateTypeError:
                    pass
            base = values.get(key, MISSING)
            base = spec.initial() if base is MISSING else copy.copy(base)  # a reducer may change its input
            if base is MISSING:
                raise
            try:
                self.check_value(node, spec, spec.reducer(base, value), values)
            except Exception as refused:
                from ..contracts.errors import InputError  # here: the contracts package loads pydantic

                if isinstance(refused, InputError):  # the reducer says in its own words what is wrong with the value
                    raise StateTypeError(node, key, spec.type_name, type(value).__name__, str(refused)) from None
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
        """A new thread's values: model defaults, and the empty value of each reducer key (as LangGraph).

        Fresh objects every time: a default list appended to in one thread must not show up in another.
        """
        values = {k: s.initial() for k, s in self.keys.items() if s.empty is not None}
        values.update({k: copy.deepcopy(s.default) for k, s in self.keys.items() if s.default is not MISSING})
        return values

    def to_node_input(self, values: Mapping[str, Any]) -> Any:
        """The state as a node receives it: a dict for a TypedDict, a model instance for a model."""
        if self.is_model:
            return self.schema.model_construct(**values)
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
