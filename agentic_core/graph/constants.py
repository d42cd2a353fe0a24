"""The two virtual nodes every graph has: where a run enters and where it leaves."""

from typing import Final

START: Final = "__start__"
END: Final = "__end__"
INTERRUPT_KEY: Final = "__interrupt__"
RESERVED_NAMES: Final = frozenset({START, END, INTERRUPT_KEY})
