"""Tiny ONNX models for the detector's tests: one image input, one constant output of our choosing."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pytest

onnx = pytest.importorskip("onnx")
pytest.importorskip("onnxruntime")
from onnx import TensorProto, helper, numpy_helper  # noqa: E402


def constant_model(
    path: Path,
    output: np.ndarray,
    *,
    input_shape: Sequence[int | str] = (1, 3, 320, 320),
    metadata: Mapping[str, str] | None = None,
    extra_input: bool = False,
) -> Path:
    """A model whose output is ``output`` whatever the image (the image still feeds the graph, times zero)."""
    const = numpy_helper.from_array(output.astype(np.float32), name="const")
    nodes = [
        helper.make_node("ReduceMean", ["images"], ["mean"], keepdims=0),
        helper.make_node("Mul", ["mean", "zero"], ["nothing"]),
        helper.make_node("Add", ["const", "nothing"], ["output0"]),
    ]
    inputs = [helper.make_tensor_value_info("images", TensorProto.FLOAT, list(input_shape))]
    if extra_input:
        inputs.append(helper.make_tensor_value_info("other", TensorProto.FLOAT, [1]))
    graph = helper.make_graph(
        nodes,
        "constant_yolo",
        inputs,
        [helper.make_tensor_value_info("output0", TensorProto.FLOAT, list(output.shape))],
        initializer=[const, numpy_helper.from_array(np.zeros((), np.float32), name="zero")],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 13)])
    model.ir_version = 8
    for key, value in (metadata or {}).items():
        entry = model.metadata_props.add()
        entry.key, entry.value = key, value
    onnx.checker.check_model(model)
    onnx.save(model, str(path))
    return path


def v8_output(rows: Sequence[Sequence[float]]) -> np.ndarray:
    """YOLOv8 layout (1, 4+nc, N) from rows ``cx, cy, w, h, score...``."""
    return np.asarray(rows, dtype=np.float32).T[None]


def v5_output(rows: Sequence[Sequence[float]]) -> np.ndarray:
    """YOLOv5 layout (1, N, 5+nc) from rows ``cx, cy, w, h, objectness, score...``."""
    return np.asarray(rows, dtype=np.float32)[None]
