"""Our person detector: the network, its training on rendered frames (``python -m evaluation.detector.train``, the
``train`` extra), its calibration, and its report by altitude and pose (``python -m evaluation.detector.report``).
What runs in flight is only the exported ONNX file, through :class:`agentic_core.perception.detectors.OnnxDetector`."""
