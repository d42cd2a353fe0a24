"""Start training from weights already shipped: a :class:`PersonNet` rebuilt from its ONNX export.

Why: a fresh training run on this machine takes about an hour; fine-tuning the shipped network on the frames it is
weak on (close range, lying persons) takes a fraction of that and keeps what it already knows. The export folds
each batch normalisation into the convolution before it, so the convolutions take the exported weights and biases
and each normalisation becomes the identity (mean 0, variance 1 − eps, scale 1, shift 0); :func:`freeze_norms`
keeps it that way while the rest trains (batch statistics would undo the folding).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from agentic_core.contracts.extras import require


def _initialisers(path: Path) -> dict[str, tuple[Any, Any]]:
    """Each convolution of the export, by the module it came from (``down16.1``, ``head.1``), as (weight, bias)."""
    onnx: Any = require("onnx", "train")
    from onnx import numpy_helper

    model = onnx.load(str(path))
    arrays = {init.name: numpy_helper.to_array(init) for init in model.graph.initializer}
    for node in model.graph.node:  # equal tensors (fresh biases) are saved once, the others as Identity of it
        if node.op_type == "Identity" and node.input[0] in arrays:
            arrays[node.output[0]] = arrays[node.input[0]]
        elif node.op_type == "DequantizeLinear" and node.input[0] in arrays:  # an int8 export's weights
            arrays[node.output[0]] = _dequantised(node, arrays)
    out: dict[str, tuple[Any, Any]] = {}
    for node in model.graph.node:
        if node.op_type == "Conv" and node.name.startswith("/net/") and len(node.input) == 3:
            module = node.name.split("/")[-2]  # /net/down16/down16.1/down16.1.0/Conv: down16.1.0, or up16
            out[module.rsplit(".", 1)[0] if node.name.count("/") == 5 else module] = (
                arrays[node.input[1]],
                arrays[node.input[2]],
            )
    return out


def _dequantised(node: Any, arrays: dict[str, Any]) -> Any:
    """The float tensor a DequantizeLinear of constants gives: (q − zero point) × scale, per tensor or per channel
    along its ``axis``."""
    q = arrays[node.input[0]].astype(np.float32)
    scale = np.asarray(arrays[node.input[1]], np.float32)
    zero = np.asarray(arrays[node.input[2]], np.float32) if len(node.input) > 2 and node.input[2] else 0.0
    axis = next((int(a.i) for a in node.attribute if a.name == "axis"), 1)
    if scale.ndim == 1 and q.ndim > 1:
        shape = [1] * q.ndim
        shape[axis] = -1
        scale = scale.reshape(shape)
        zero = np.asarray(zero, np.float32).reshape(shape) if np.ndim(zero) == 1 else zero
    return (q - zero) * scale


def net_from_onnx(path: Path, width: int, *, context32: bool = False) -> Any:
    """A :class:`PersonNet` of ``width`` with the weights of the ONNX export at ``path``; a stride-32 branch
    (``context32``) the export lacks keeps its fresh weights, its way back zero (:class:`ValueError` when the
    export has a convolution the network lacks or of another shape)."""
    torch: Any = require("torch", "train")
    from .network import PersonNet

    net = PersonNet(width, context32=context32)
    modules = dict(net.named_modules())
    with torch.no_grad():
        for name, (weight, bias) in _initialisers(path).items():
            block = modules.get(name)
            if block is None:
                raise ValueError(f"{path}: a convolution {name} the network of width {width} lacks")
            conv = block[0] if isinstance(block, torch.nn.Sequential) else block
            if tuple(weight.shape) != tuple(conv.weight.shape):
                raise ValueError(f"{path}: {name} has shape {weight.shape}, not {tuple(conv.weight.shape)}")
            conv.weight.copy_(torch.from_numpy(np.array(weight)))
            if isinstance(block, torch.nn.Sequential):  # convolution, normalisation folded into it, ReLU
                norm = block[1]
                norm.running_mean.zero_()
                norm.running_var.fill_(1.0 - norm.eps)
                norm.weight.fill_(1.0)
                norm.bias.copy_(torch.from_numpy(np.array(bias)))
            else:
                conv.bias.copy_(torch.from_numpy(np.array(bias)))
    return net


def freeze_norms(net: Any) -> None:
    """Put every batch normalisation of ``net`` in eval mode (its folded statistics kept while the rest trains)."""
    torch: Any = require("torch", "train")
    for module in net.modules():
        if isinstance(module, torch.nn.BatchNorm2d):
            module.eval()


__all__ = ["freeze_norms", "net_from_onnx"]
