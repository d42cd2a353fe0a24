"""With rendering on, the alert's picture is the rendered view: the ground's texture, the casualty boxed in red
with its position written under it, and not the schematic's flat background."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from matplotlib.image import imread

from agentic_core.perception.annotate import position_text
from agentic_core.run.attachments import materialize
from agentic_core.run.perception_loop import PerceptionLoop
from flight.camera import CameraPose
from flight.sim.scene_file import load_scene

SCENE = Path(__file__).resolve().parents[3] / "scenes" / "hajj_emergency.yaml"
GROUND = np.array([0x6B, 0x62, 0x56])
"""The schematic's flat ground (annotate's background without pixels)."""


def _hover(render: bool, frames: int = 3) -> PerceptionLoop:
    loop = PerceptionLoop(load_scene(SCENE), seed=1, render=render)
    casualty = loop.scene.actor("P-12").position
    pose = CameraPose(north_m=casualty.north - 4.0, east_m=casualty.east, down_m=-30.0)
    for k in range(frames):
        loop.observe(pose, k * loop.camera.spec.frame_period_s)
    return loop


def _picture(loop: PerceptionLoop, tmp_path: Path) -> np.ndarray:
    out = materialize(
        {"subject": "Collapse", "attach": ["snapshot"]}, out_dir=tmp_path, stamp="s", loop=loop,
        position=lambda: None, last_decision=lambda: None,
    )  # fmt: skip
    data = Path(out["attach"][0]).read_bytes()
    pixels = np.asarray(imread(io.BytesIO(data), format="png"))
    return (pixels[:, :, :3] * 255).round().astype(np.uint8) if pixels.dtype != np.uint8 else pixels[:, :, :3]


def test_the_alert_carries_the_rendered_frame(tmp_path: Path) -> None:
    loop = _hover(render=True)
    frame = loop.perception._last[0] if loop.perception._last else None
    assert frame is not None and frame.image is not None and frame.image.shape == (480, 640, 3)
    picture = _picture(loop, tmp_path)
    assert picture.shape == (480, 640, 3)
    middle = picture[120:360, 100:540].reshape(-1, 3).astype(int)
    assert (np.abs(middle - GROUND).sum(axis=1) <= 6).mean() < 0.05  # not the schematic's flat ground
    assert middle.std(axis=0).min() > 4  # textured
    rendered = frame.image[120:360, 100:540].reshape(-1, 3).astype(int)
    same = (np.abs(middle - rendered).sum(axis=1) <= 3).mean()
    assert same > 0.5  # mostly the rendered frame itself, annotations on top


def test_without_rendering_the_alert_keeps_the_schematic(tmp_path: Path) -> None:
    loop = _hover(render=False)
    picture = _picture(loop, tmp_path)
    middle = picture[200:300, 200:400].reshape(-1, 3).astype(int)
    assert (np.abs(middle - GROUND).sum(axis=1) <= 6).mean() > 0.8


def test_position_text() -> None:
    assert position_text(21.4133, 39.8933) == "21.41330° N, 39.89330° E"
    assert position_text(-1.5, -0.25) == "1.50000° S, 0.25000° W"
