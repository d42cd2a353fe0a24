"""The YAML position lookup the scene and mission loaders share: value, key, nearest ancestor, last duplicate."""

import doctest

import yaml

from agentic_core.contracts import yaml_positions
from agentic_core.contracts.yaml_positions import node_position, position_at

TEXT = """\
id: x
seed: 1
actors:
  - {id: P-1, behaviour: lying}
  - id: P-2
    seed: 2
seed: 3
"""


def compose(text: str) -> yaml.Node:
    root = yaml.compose(text)
    assert root is not None
    return root


ROOT = compose(TEXT)


def test_the_value_and_with_key_its_key() -> None:
    assert position_at(ROOT, ("actors", 0, "behaviour")) == (4, 26)
    assert position_at(ROOT, ("actors", 0, "behaviour"), key=True) == (4, 15)
    assert position_at(ROOT, ()) == (1, 1)


def test_a_list_item_has_no_key_so_key_gives_the_item() -> None:
    assert position_at(ROOT, ("actors", 1), key=True) == position_at(ROOT, ("actors", 1)) == (5, 5)


def test_a_missing_last_part_gives_its_parent_even_with_key() -> None:
    assert position_at(ROOT, ("actors", 1, "zone")) == (5, 5)
    assert position_at(ROOT, ("actors", 1, "zone"), key=True) == (5, 5)
    assert position_at(ROOT, ("nowhere",)) == (1, 1)


def test_a_list_index_out_of_range_gives_the_list() -> None:
    assert position_at(ROOT, ("actors", 2, "id")) == (4, 3)
    assert position_at(ROOT, ("actors", -1, "id")) == (4, 3)
    assert position_at(ROOT, ("id", 0)) == (1, 5)  # an index into a scalar: the scalar


def test_of_duplicate_keys_the_last_wins() -> None:
    assert position_at(ROOT, ("seed",)) == (7, 7)
    assert position_at(ROOT, ("seed",), key=True) == (7, 1)


def test_a_number_part_matches_a_key_written_as_a_number() -> None:
    assert position_at(compose("codes:\n  7: seven\n"), ("codes", 7)) == (2, 6)


def test_node_position_is_one_based() -> None:
    assert node_position(ROOT) == (1, 1)
    assert doctest.testmod(yaml_positions).failed == 0
