"""Records built without validating them again: for the few places that make hundreds of contract records a frame
from their own checked arrays (perception's World Model, the simulated detector's detections).

They are made as pydantic's ``model_construct`` makes records, without its per-field alias and default lookups:
``__dict__`` set to values that are exactly what validation would give (``float`` for every float field, not an
``int`` or numpy scalar; tuples for tuples; records for nested records), every field given. Each user's tests
hold its records equal, field by field, in ``model_fields_set`` and in JSON, to validated ones, and such records
must have no validators that would change a value, no private attributes and no ``model_post_init``, which this
skips.

>>> from agentic_core.contracts.camera import BoundingBox
>>> new_box = record_maker(BoundingBox)
>>> new_box({"x_min": 1.0, "y_min": 2.0, "x_max": 3.0, "y_max": 4.0}) == BoundingBox(x_min=1, y_min=2, x_max=3, y_max=4)
True
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from collections.abc import Set as AbstractSet
from typing import Any, Self, TypeVar, cast

from pydantic import BaseModel


def _slot_setter(name: str) -> Callable[[Any, Any], None]:
    """The setter of one of pydantic's instance slots (``__dict__``, ``__pydantic_fields_set__``, ...), called
    directly: a third faster than ``object.__setattr__``, which looks the slot up through the class every time."""
    slot = vars(BaseModel).get(name)
    setter = getattr(slot, "__set__", None)
    if setter is None:  # not a slot in some pydantic version: set it as model_construct does
        return lambda obj, value: object.__setattr__(obj, name, value)
    return cast("Callable[[Any, Any], None]", setter)


_set_dict = _slot_setter("__dict__")
_set_fields_set = _slot_setter("__pydantic_fields_set__")
_set_extra = _slot_setter("__pydantic_extra__")
_set_private = _slot_setter("__pydantic_private__")
_SHARED = "the fields-set of a record built from trusted values is shared by its class's records: copy it to change it"


class AllFields(set[str]):
    """Every field name of one record class: the ``model_fields_set`` that records built from trusted values share.

    Every record sets every field, so they can share one set instead of allocating one each, which was a third of
    the cost of a record (a set of more than four names allocates a table of its own). It is a ``set``, equal to
    the one validation makes, but it refuses to change, since it is shared: pydantic only ever adds a name already
    in it (on assigning a field: no change), and a copy (``copy()``, ``model_copy``, ``copy.copy``, pickling) is an
    ordinary set.
    """

    def add(self, element: str) -> None:
        if element not in self:
            raise TypeError(_SHARED)

    def update(self, *s: Iterable[str]) -> None:
        if any(element not in self for other in s for element in other):
            raise TypeError(_SHARED)

    def __ior__(self, value: AbstractSet[str]) -> Self:  # type: ignore[override,misc]
        self.update(value)
        return self

    def discard(self, element: object) -> None:
        raise TypeError(_SHARED)

    def remove(self, element: str) -> None:
        raise TypeError(_SHARED)

    def pop(self) -> str:
        raise TypeError(_SHARED)

    def clear(self) -> None:
        raise TypeError(_SHARED)

    def difference_update(self, *s: Iterable[Any]) -> None:
        raise TypeError(_SHARED)

    def intersection_update(self, *s: Iterable[Any]) -> None:
        raise TypeError(_SHARED)

    def symmetric_difference_update(self, s: Iterable[str], /) -> None:
        raise TypeError(_SHARED)

    def __iand__(self, value: AbstractSet[object]) -> Self:
        raise TypeError(_SHARED)

    def __isub__(self, value: AbstractSet[object]) -> Self:
        raise TypeError(_SHARED)

    def __ixor__(self, value: AbstractSet[str]) -> Self:  # type: ignore[override,misc]
        raise TypeError(_SHARED)

    def copy(self) -> set[str]:
        return set(self)

    def __copy__(self) -> set[str]:
        return set(self)

    def __deepcopy__(self, memo: dict[int, Any]) -> set[str]:
        return set(self)

    def __reduce__(self) -> tuple[type[set[str]], tuple[list[str]]]:
        return set, (list(self),)


M = TypeVar("M", bound=BaseModel)


def record_maker(cls: type[M]) -> Callable[[dict[str, Any]], M]:
    """A function that makes a ``cls`` record from a dict of every field's value, already what validation would
    give (see the module docs); the records share one :class:`AllFields`."""
    new, fields = cls.__new__, AllFields(cls.model_fields)
    set_dict, set_fields_set, set_extra, set_private = _set_dict, _set_fields_set, _set_extra, _set_private

    def make(values: dict[str, Any]) -> M:
        record = new(cls)
        set_dict(record, values)
        set_fields_set(record, fields)
        set_extra(record, None)
        set_private(record, None)
        return record

    return make


__all__ = ["AllFields", "record_maker"]
