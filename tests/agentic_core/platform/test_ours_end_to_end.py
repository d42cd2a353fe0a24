"""``agentic-uav run missions/hajj_emergency.yaml --detector ours`` over the mission's own scene (hundreds of
pilgrims on the road): the shipped detector, on rendered frames, finds the collapsed pilgrim, the run judges them
critical, mails the medical team with the rendered frame attached (not the schematic), and lands beside them with
the kit. The run is landed by the test once the kit is out (the flight home adds nothing here)."""

from __future__ import annotations

import email
from email.message import Message
from io import BytesIO
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("onnxruntime")

from agentic_core.contracts import RunEvent
from agentic_core.run.runner import MissionRun, RunSettings

from .conftest import EMERGENCY, REPO, assert_served, of_kind

SCENE = REPO / "scenes" / "hajj_emergency.yaml"


def _png_pixels(data: bytes) -> np.ndarray:
    import matplotlib.image as mpimg

    pixels = mpimg.imread(BytesIO(data), format="png")
    return (pixels[:, :, :3] * 255).round().astype(np.uint8) if pixels.dtype != np.uint8 else pixels[:, :, :3]


@pytest.mark.slow
@pytest.mark.xfail(
    strict=True,
    reason="the trigger acts on the casualty, but at 15 m the shipped detector puts two boxes on the one lying "
    "person (IoU 0.21 with each other, so NMS keeps both): two still tracks 1 m apart, neither isolated_from the "
    "other, and confirm judges severity none (or fails its min_confidence 0.5 on the two tracks' mean); no alert",
)
def test_our_detector_finds_alerts_and_serves_the_casualty(tmp_path: Path, smtp: Any) -> None:
    run = MissionRun(
        RunSettings(
            mission=EMERGENCY, scene=SCENE, runs_dir=tmp_path / "runs", params={"rounds": "1", "still_s": "4"},
            detector="ours", camera_hz=10.0,
        )
    )  # fmt: skip

    def land_once_the_kit_is_out(event: RunEvent) -> None:
        fields = event.fields()
        if event.kind == "tool" and fields.get("name") == "flight.deploy_payload" and fields["status"] == "ok":
            run.control.land(by="test")

    run.bus.subscribe(land_once_the_kit_is_out)
    result = run.execute()
    assert result.summary.outcome == "landed", result.summary
    records = assert_served(result.run_dir, smtp)
    acted = [r for r in of_kind(records, "trigger") if r["act"]]
    linked = [r for r in of_kind(records, "log") if r.get("truth") == "P-12"]
    assert linked and acted[0]["event"] in {r["object"] for r in linked}  # the person found is the casualty
    (envelope,) = smtp.inbox.envelopes
    message: Message = email.message_from_bytes(envelope.content)
    pictures = [p for p in message.walk() if p.get_content_type() == "image/png"]
    assert pictures, [p.get_content_type() for p in message.walk()]
    payload = pictures[0].get_payload(decode=True)
    assert isinstance(payload, bytes)
    picture = _png_pixels(payload)
    middle = picture[120:360, 100:540].reshape(-1, 3).astype(int)
    assert middle.std(axis=0).min() > 4  # the rendered ground's texture, not the schematic's flat colour
