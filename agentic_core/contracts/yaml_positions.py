"""Where a value is written in a YAML file: 1-based line and column found by its path in PyYAML's composed tree.

Shared by the scene loader (``flight.sim.scene_file``) and the mission loader (``agentic_core.mission.source``),
which report through :class:`~agentic_core.contracts.problems.LocatedProblem`; it lives in the contracts, the one
layer both may import.

>>> root = yaml.compose("steps:\\n  - {id: up, action: takeoff}\\n")
>>> position_at(root, ("steps", 0, "action")), position_at(root, ("steps", 0, "action"), key=True)
((2, 22), (2, 14))
"""

from __future__ import annotations

from collections.abc import Sequence

import yaml


def node_position(node: yaml.Node) -> tuple[int, int]:
    """The 1-based line and column where ``node`` starts (PyYAML's marks count from 0)."""
    mark = node.start_mark
    return mark.line + 1, mark.column + 1


KeyIndex = dict[int, dict[str, tuple[yaml.Node, yaml.Node]]]
"""Each mapping node's keys by name (key node, value node), by the mapping node's ``id``: valid while the tree lives."""


def position_at(
    root: yaml.Node, path: Sequence[str | int], *, key: bool = False, index: KeyIndex | None = None
) -> tuple[int, int]:
    """The position of the value at ``path`` (mapping keys, list indexes), of its key with ``key``, or of the
    nearest ancestor that exists (a missing field: its parent); of duplicate keys the last wins, as in loading.

    ``index``, kept by the caller as long as ``root``, makes each mapping's keys a lookup after the first time:
    without it every lookup scans the mapping, and a problem for each of 40,000 keys took 40 s to place."""
    node, key_node, depth = root, None, 0
    for part in path:
        nxt: yaml.Node | None = None
        if isinstance(node, yaml.MappingNode):
            name = str(part)
            if index is not None:
                keys = index.get(id(node))
                if keys is None:  # in order written, so of duplicate keys the last stays
                    keys = index[id(node)] = {k.value: (k, v) for k, v in node.value if isinstance(k, yaml.ScalarNode)}
                if name in keys:
                    key_node, nxt = keys[name]
            else:
                for k, v in reversed(node.value):
                    if isinstance(k, yaml.ScalarNode) and k.value == name:
                        nxt, key_node = v, k
                        break
        elif isinstance(node, yaml.SequenceNode) and isinstance(part, int) and 0 <= part < len(node.value):
            nxt, key_node = node.value[part], None
        if nxt is None:
            break
        node, depth = nxt, depth + 1
    return node_position(key_node if key and key_node is not None and depth == len(path) else node)


__all__ = ["KeyIndex", "node_position", "position_at"]
