"""Checkpointers: where a thread's state is saved after every superstep."""

from .base import BaseCheckpointSaver, Checkpoint, PickleSerializer, Serializer
from .memory import InMemorySaver, MemorySaver
from .sqlite import SqliteSaver

__all__ = [
    "BaseCheckpointSaver",
    "Checkpoint",
    "InMemorySaver",
    "MemorySaver",
    "PickleSerializer",
    "Serializer",
    "SqliteSaver",
]
