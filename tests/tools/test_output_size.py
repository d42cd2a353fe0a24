"""The output's size as JSON, counted without serialising it: never under the compact JSON's length, at most a
byte over it per container (escapes aside), and the walk stops once past the limit."""

import dataclasses
import datetime
import enum
import json
import re
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pydantic import BaseModel

from tools.output_size import configured_limit, measure

PRINTABLE = st.text(st.characters(min_codepoint=0x20, max_codepoint=0x2FFF, exclude_characters='"\\'), max_size=8)
SCALARS = st.none() | st.booleans() | st.integers(-(2**63), 2**63) | st.floats(allow_nan=False, allow_infinity=False)
JSON = st.recursive(
    SCALARS | PRINTABLE,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(PRINTABLE, inner, max_size=4),
    max_leaves=30,
)


def compact(value: Any) -> int:
    return len(json.dumps(value, separators=(",", ":"), ensure_ascii=False).encode())


def containers(value: Any) -> int:
    if isinstance(value, dict):
        return 1 + sum(containers(v) for v in value.values())
    if isinstance(value, list):
        return 1 + sum(containers(v) for v in value)
    return 0


@settings(max_examples=300, deadline=None)
@given(JSON)
def test_the_count_brackets_the_compact_json(value: Any) -> None:
    exact = compact(value)
    size, problem = measure(value, 10**9)
    assert problem is None
    assert exact <= size <= exact + containers(value)
    over = measure(value, exact - 1)  # a limit the value is over
    assert over.problem is not None and over.problem.startswith("too large:")


def test_a_huge_int_is_counted_by_its_digits_without_printing_it() -> None:
    big = 7**200_000  # 169,020 digits: str() would refuse it (and cost it)
    size, problem = measure([big], 10**6)
    assert problem is None and abs(size - 169_021) < 5


class Colour(enum.Enum):
    RED = "red"


@dataclasses.dataclass
class Fix:
    lat: float
    when: datetime.datetime


class Report(BaseModel):
    fix: Fix
    colour: Colour


def test_models_dataclasses_and_common_scalars_are_data() -> None:
    value = Report(fix=Fix(21.4, datetime.datetime(2026, 1, 1, tzinfo=datetime.UTC)), colour=Colour.RED)
    size, problem = measure(value, 10**6)
    assert problem is None and size >= len(value.model_dump_json())


@pytest.mark.parametrize(
    ("value", "problem"),
    [
        ({"f": print}, "not JSON data: $.f is a builtin_function_or_method"),
        ([1, {"k": object()}], "not JSON data: $[1].k is an object"),
        ({"t": Fix}, "not JSON data: $.t is a type"),
        (iter([1]), "not JSON data: $ is a list_iterator"),
        ({"x" * 500: lambda: 0}, "not JSON data: $." + "x" * 40 + "... is a function"),
    ],
)
def test_what_is_not_data_is_named_by_its_path(value: Any, problem: str) -> None:
    assert measure(value, 10**6).problem == problem


def test_a_mapping_of_ten_million_items_is_walked_only_to_the_limit() -> None:
    class Endless(dict[str, int]):
        def items(self) -> Any:
            return ((f"k{i}", i) for i in range(10**12))

    problem = measure(Endless(), 1000).problem
    assert problem is not None
    assert re.fullmatch(r"too large: 10\d\d bytes of JSON or more, over the limit of 1000", problem)


def test_configured_limit_reads_positive_whole_numbers_only() -> None:
    assert configured_limit({"AGENTIC_UAV_MAX_TOOL_OUTPUT_BYTES": " 12 "}) == 12


def test_numpy_scalars_are_data_and_arrays_count_their_bytes() -> None:
    import numpy as np

    assert measure({"a": np.float32(1.5), "b": np.int64(3), "c": np.bool_(True)}, 1000).problem is None
    size, problem = measure(np.zeros((1000, 1000)), 10**9)  # eight million bytes of float64
    assert problem is None and size >= 8_000_000
    assert measure(np.zeros((1000, 1000)), 10**6).problem is not None
