"""Turning text into vectors for the store: the offline all-MiniLM-L6-v2 (the ``embed`` extra) or any function.

:func:`resolve` takes what an index config's ``embed`` names: ``"all-MiniLM-L6-v2"`` (our numpy forward pass),
a function ``list[str] -> list[list[float]]``, or an object with LangChain's ``embed_documents``/``embed_query``.
:func:`available` says whether the model can run here; without it a store ranks by words (BM25) alone.
"""

from __future__ import annotations

from .base import Embedder, FunctionEmbedder, available, resolve

__all__ = ["Embedder", "FunctionEmbedder", "available", "resolve"]
