"""The two virtual nodes every graph has: where a run enters and where it leaves."""

from typing import Final

START: Final = "__start__"
END: Final = "__end__"
INTERRUPT_KEY: Final = "__interrupt__"
STORE_KEY: Final = "__store__"  # a subgraph's config carries its parent's store under this configurable key
RESERVED_NAMES: Final = frozenset({START, END, INTERRUPT_KEY})
