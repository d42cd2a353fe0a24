"""Real detectors behind the :class:`~agentic_core.contracts.camera.Detector` protocol: :class:`OnnxDetector` runs
a YOLO-style ONNX model (the ``vision`` extra); ``ours`` is the person detector trained here on rendered frames."""

from __future__ import annotations

from .onnx import OnnxDetector

__all__ = ["OnnxDetector"]
