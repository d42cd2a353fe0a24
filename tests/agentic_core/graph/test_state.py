"""State schemas: reducers, last-value conflicts and typed validation of node updates."""

import operator
from typing import Annotated, Any, TypedDict

import pytest
from pydantic import BaseModel

from agentic_core.graph import END, START, InvalidUpdateError, StateGraph, StateTypeError


class Counter(TypedDict, total=False):
    count: int
    log: Annotated[list[str], operator.add]
    total: Annotated[int, operator.add]


def one_node(schema: Any, fn: Any) -> Any:
    g = StateGraph(schema)
    g.add_node("n", fn)
    g.add_edge(START, "n")
    g.add_edge("n", END)
    return g.compile()


def parallel(schema: Any, a: Any, b: Any) -> Any:
    g = StateGraph(schema)
    g.add_node("a", a)
    g.add_node("b", b)
    g.add_edge(START, "a")
    g.add_edge(START, "b")
    g.add_edge("a", END)
    g.add_edge("b", END)
    return g.compile()


def test_reducer_keys_merge_and_last_value_keys_replace() -> None:
    app = one_node(Counter, lambda s: {"count": 7, "log": ["x"], "total": 5})
    assert app.invoke({"count": 1, "log": ["start"], "total": 1}) == {"count": 7, "log": ["start", "x"], "total": 6}


def test_reducer_starts_from_the_empty_value_of_its_type() -> None:
    app = one_node(Counter, lambda s: {"total": 5, "log": ["x"]})
    assert app.invoke({"count": 0}) == {"count": 0, "total": 5, "log": ["x"]}


def test_parallel_writes_to_a_reducer_key_merge_in_task_order() -> None:
    app = parallel(Counter, lambda s: {"log": ["a"]}, lambda s: {"log": ["b"]})
    assert app.invoke({"log": []})["log"] == ["a", "b"]


def test_two_writes_to_a_last_value_key_name_both_nodes_and_the_key() -> None:
    app = parallel(Counter, lambda s: {"count": 1}, lambda s: {"count": 2})
    with pytest.raises(InvalidUpdateError) as err:
        app.invoke({"count": 0})
    msg = str(err.value)
    assert "'a'" in msg and "'b'" in msg and "'count'" in msg and "reducer" in msg


def test_unknown_key_names_node_key_and_known_keys() -> None:
    app = one_node(Counter, lambda s: {"cuont": 1})
    with pytest.raises(InvalidUpdateError) as err:
        app.invoke({"count": 0})
    msg = str(err.value)
    assert "node 'n'" in msg and "'cuont'" in msg and "count" in msg and "log" in msg


def test_wrong_type_names_node_key_expected_and_given_type() -> None:
    app = one_node(Counter, lambda s: {"count": "3"})
    with pytest.raises(StateTypeError) as err:
        app.invoke({"count": 0})
    e = err.value
    assert (e.node, e.key, e.expected, e.given) == ("n", "count", "int", "str")
    assert "node 'n'" in str(e) and "'count'" in str(e)


def test_wrong_item_type_inside_a_list_is_located() -> None:
    app = one_node(Counter, lambda s: {"log": [1]})
    with pytest.raises(StateTypeError) as err:
        app.invoke({"count": 0})
    assert err.value.key == "log" and "at 0" in str(err.value)


def test_wrong_input_type_is_reported_as_input() -> None:
    app = one_node(Counter, lambda s: None)
    with pytest.raises(StateTypeError) as err:
        app.invoke({"count": 1.5})
    assert err.value.node == "__input__"


def test_returning_a_non_dict_says_what_a_node_may_return() -> None:
    app = one_node(Counter, lambda s: 42)
    with pytest.raises(InvalidUpdateError, match="must return a dict"):
        app.invoke({"count": 0})


def add_one_or_many(left: list[str], right: str | list[str]) -> list[str]:
    return left + ([right] if isinstance(right, str) else right)


class Chat(TypedDict, total=False):
    messages: Annotated[list[str], add_one_or_many]


def test_reducer_that_takes_single_items_is_accepted() -> None:
    app = one_node(Chat, lambda s: {"messages": "hello"})
    assert app.invoke({"messages": ["hi"]}) == {"messages": ["hi", "hello"]}


class Pose(BaseModel):
    north_m: float
    east_m: float


class Mission(BaseModel):
    pose: Pose
    waypoints: Annotated[list[Pose], operator.add] = []
    battery: float = 1.0


def test_pydantic_state_nodes_get_a_model_and_dicts_become_models() -> None:
    seen: list[Any] = []

    def fly(state: Mission) -> dict[str, Any]:
        seen.append(state)
        return {"pose": {"north_m": 10, "east_m": 5}, "waypoints": [{"north_m": 10, "east_m": 5}]}

    out = one_node(Mission, fly).invoke({"pose": Pose(north_m=0, east_m=0)})
    assert isinstance(seen[0], Mission) and seen[0].battery == 1.0
    assert out["pose"] == Pose(north_m=10, east_m=5)
    assert out["waypoints"] == [Pose(north_m=10, east_m=5)]
    assert out["battery"] == 1.0


def test_pydantic_state_missing_required_field_is_named() -> None:
    app = one_node(Mission, lambda s: None)
    with pytest.raises(InvalidUpdateError, match="pose"):
        app.invoke({"battery": 0.5})


def test_pydantic_state_rejects_a_string_for_a_float() -> None:
    app = one_node(Mission, lambda s: {"battery": "full"})
    with pytest.raises(StateTypeError) as err:
        app.invoke({"pose": Pose(north_m=0, east_m=0)})
    assert err.value.key == "battery" and err.value.given == "str"


def test_schema_must_be_typeddict_or_model() -> None:
    with pytest.raises(Exception, match="TypedDict or a pydantic BaseModel"):
        StateGraph(dict)
