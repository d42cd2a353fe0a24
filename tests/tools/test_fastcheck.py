"""The fast check of flat argument schemas agrees with jsonschema on every input (it may only ever say "valid"
when jsonschema does and no number is NaN or infinite, and should say so whenever both hold, but for undeclared
arguments holding lists or objects, which it leaves to the full check)."""

from typing import Any

import jsonschema
from hypothesis import given, settings
from hypothesis import strategies as st

from tools.arguments import non_finite
from tools.fastcheck import flat_checker

NAMES = st.sampled_from(["lat", "lon", "alt", "mode", "armed"])
VALUES = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-5, 5),
    st.floats(),
    st.sampled_from([1.0, 2.0, -0.0]),
    st.text(max_size=3),
    st.lists(st.one_of(st.integers(), st.floats()), max_size=2),
    st.dictionaries(st.text(max_size=2), st.one_of(st.integers(), st.floats()), max_size=1),
)


@st.composite
def flat_schemas(draw: Any) -> dict[str, Any]:
    names = draw(st.lists(NAMES, unique=True, max_size=4))
    types = {n: draw(st.sampled_from(["string", "integer", "number", "boolean"])) for n in names}
    schema: dict[str, Any] = {"type": "object", "properties": {n: {"type": t} for n, t in types.items()}}
    if names:
        schema["required"] = draw(st.lists(st.sampled_from(names), unique=True))
    if draw(st.booleans()):
        schema["additionalProperties"] = draw(st.booleans())
    return schema


@settings(max_examples=400)
@given(flat_schemas(), st.dictionaries(st.one_of(NAMES, st.text(max_size=3)), VALUES, max_size=5))
def test_the_fast_check_agrees_with_jsonschema(schema: dict[str, Any], args: dict[str, Any]) -> None:
    check = flat_checker(schema)
    assert check is not None
    valid = jsonschema.Draft202012Validator(schema).is_valid(args) and not non_finite(args)
    declared = schema["properties"]
    nested = any(isinstance(v, dict | list) for name, v in args.items() if name not in declared)
    assert check(args) == (valid and not nested)  # nested: left to the full check, valid or not


def test_schemas_that_are_not_flat_are_left_to_jsonschema() -> None:
    assert flat_checker({"type": "object", "properties": {"p": {"type": "object"}}}) is None
    assert flat_checker({"type": "object", "properties": {"n": {"type": "integer", "minimum": 0}}}) is None
    assert flat_checker({"type": "object", "properties": {"s": {"type": "string", "format": "email"}}}) is None
    assert flat_checker({"type": "object", "additionalProperties": {"type": "string"}}) is None
    assert flat_checker({"type": "object", "$defs": {}}) is None
