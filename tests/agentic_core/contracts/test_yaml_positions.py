"""The YAML position lookup the scene and mission loaders share: value, key, nearest ancestor, last duplicate."""

import doctest

import yaml

from agentic_core.contracts import yaml_positions
from agentic_core.contracts.yaml_positions import KeyIndex, node_position, position_at

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


def test_an_index_of_mapping_keys_places_every_path_where_a_scan_does() -> None:
    """With a key index (a mission's 40,000 unknown dependencies took 40 s to place, one scan of the mapping per
    problem; 2.5 s with it) every path lands where the scan puts it: duplicate keys (the last wins), missing keys
    and indexes (the nearest ancestor), keys asked for themselves, flow and block style, the same index reused."""
    text = (
        "a: 1\nb: {x: 1, y: [10, 20, {z: 3}], x: 2}\nc:\n  - p: 1\n    q: 2\n  - {p: 3}\na: 4\nd: {}\ne: []\n1: one\n"
    )
    root = compose(text)
    paths = [
        ("a",), ("b",), ("b", "x"), ("b", "y"), ("b", "y", 1), ("b", "y", 2, "z"), ("b", "y", 5), ("b", "w"),
        ("c", 0, "q"), ("c", 1, "p"), ("c", 2, "p"), ("d", "k"), ("e", 0), (1,), ("nowhere", "at", "all"), (),
    ]  # fmt: skip
    index: KeyIndex = {}
    for _ in range(2):  # built on the first pass, read on the second
        for path in paths:
            for key in (False, True):
                assert position_at(root, path, key=key, index=index) == position_at(root, path, key=key), (path, key)
    assert position_at(root, ("b", "x"), index=index) == (2, 35)  # the second x
    assert len(index) == 6  # the mappings looked into: the root, b, its z mapping, c's two items and d
