"""``agentic-uav run missions/hajj_emergency.yaml --detector ours`` over the mission's own scene (hundreds of
pilgrims on the road): the shipped detector, on rendered frames, finds the collapsed pilgrim from the patrol
altitude, keeps them one person at the close look (not two tracks a metre apart), the run judges them critical,
mails the medical team with the rendered frame attached (not the schematic), lands beside them with the kit and
flies home: exit 0. One patrol pass and four seconds of stillness (the mission's params) keep it short."""

from __future__ import annotations

import email
from email.message import Message
from io import BytesIO
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("onnxruntime")

from agentic_core.cli import main

from .conftest import EMERGENCY, REPO, assert_served, of_kind

SCENE = REPO / "scenes" / "hajj_emergency.yaml"


def _png_pixels(data: bytes) -> np.ndarray:
    import matplotlib.image as mpimg

    pixels = mpimg.imread(BytesIO(data), format="png")
    return (pixels[:, :, :3] * 255).round().astype(np.uint8) if pixels.dtype != np.uint8 else pixels[:, :, :3]


@pytest.mark.slow
def test_our_detector_finds_alerts_and_serves_the_casualty(tmp_path: Path, smtp: Any) -> None:
    code = main(
        ["run", str(EMERGENCY), "--scene", str(SCENE), "--runs-dir", str(tmp_path), "--quiet", "--detector", "ours",
         "--camera-hz", "5", "--param", "rounds=1", "--param", "still_s=4"]
    )  # fmt: skip
    assert code == 0
    records = assert_served(next(tmp_path.iterdir()), smtp, scene=SCENE)
    acted = [r for r in of_kind(records, "trigger") if r["act"]]
    linked = [r for r in of_kind(records, "log") if r.get("truth") == "P-12"]
    assert linked and acted[0]["event"] in {r["object"] for r in linked}  # the person found is the casualty
    confirm = [r["assessment"] for r in of_kind(records, "decision") if r.get("assessment")][-1]
    assert confirm["severity"] == "critical" and confirm["persons_detected"] == 1  # one person at 15 m, not split
    (envelope,) = smtp.inbox.envelopes
    message: Message = email.message_from_bytes(envelope.content)
    pictures = [p for p in message.walk() if p.get_content_type() == "image/png"]
    assert pictures, [p.get_content_type() for p in message.walk()]
    payload = pictures[0].get_payload(decode=True)
    assert isinstance(payload, bytes)
    middle = _png_pixels(payload)[120:360, 100:540].reshape(-1, 3).astype(int)
    assert middle.std(axis=0).min() > 4  # the rendered ground's texture, not the schematic's flat colour
