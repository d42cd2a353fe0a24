"""The person detector's network (torch): a small single-class anchor-free detector with its head at stride 4, and
the wrapper that exports it in the YOLOv8 layout ``(1, 5, N)`` (``cx, cy, w, h, score``) so :class:`OnnxDetector`
runs it.

The stem reaches stride 4 through two 3×3 convolutions of stride 2, so the detail of a person five pixels wide
survives; context comes from stride 8 and stride 16 branches added back (a small feature pyramid), wide enough for a
person 60 pixels long at 10 m. Each cell of the stride-4 grid predicts a score logit (is a person's centre here?),
the centre's offset in the cell and the box's log size. The export keeps only local maxima of the score (a 3×3
max-pool), the usual way a centre-point detector avoids a crowd of neighbours each claiming one person.
"""

from __future__ import annotations

from typing import Any

from agentic_core.contracts.extras import require

torch: Any = require("torch", "train")
nn: Any = torch.nn

STRIDE = 4
OUTPUTS = 5
"""score logit, x and y offset, log width and log height."""


def _conv(cin: int, cout: int, stride: int = 1, dilation: int = 1) -> Any:
    return nn.Sequential(
        nn.Conv2d(cin, cout, 3, stride, padding=dilation, dilation=dilation, bias=False),
        nn.BatchNorm2d(cout),
        nn.ReLU(inplace=True),
    )


class PersonNet(nn.Module):  # type: ignore[misc]
    """Stem to stride 4 (two stride-2 3×3 convolutions), stride 8 and 16 context added back, a head at stride 4;
    ``context32`` adds a stride-32 branch (dilated: it sees about 300 pixels, a whole person lying 10 m below)
    into the stride-16 one, its way back zero at first so a network fine-tuned from one without it starts as
    that network."""

    def __init__(self, width: int = 24, context32: bool = False) -> None:
        super().__init__()
        w = width
        self.stem = nn.Sequential(_conv(3, 16, 2), _conv(16, w, 2), _conv(w, w))
        self.down8 = nn.Sequential(_conv(w, 2 * w, 2), _conv(2 * w, 2 * w))
        self.down16 = nn.Sequential(_conv(2 * w, 64, 2), _conv(64, 64, dilation=2))
        self.up16 = nn.Conv2d(64, 2 * w, 1)
        self.down32: Any = nn.Sequential(_conv(64, 64, 2), _conv(64, 64, dilation=2)) if context32 else None
        self.up32: Any = nn.Conv2d(64, 64, 1) if context32 else None
        if self.up32 is not None:
            nn.init.zeros_(self.up32.weight)
            nn.init.zeros_(self.up32.bias)
        self.up8 = nn.Conv2d(2 * w, w, 1)
        self.head = nn.Sequential(_conv(w, w), nn.Conv2d(w, OUTPUTS, 1))
        nn.init.constant_(self.head[-1].bias, 0.0)
        with torch.no_grad():
            self.head[-1].bias[0] = -4.6  # a prior of 1% persons per cell, so early training is not swamped

    def forward(self, images: Any) -> Any:
        """``images`` N×3×H×W in 0–1 (H and W multiples of 16, of 32 with ``context32``) → N×5×(H/4)×(W/4) raw
        outputs."""
        x4 = self.stem(images - 0.5)
        x8 = self.down8(x4)
        x16 = self.down16(x8)
        if self.down32 is not None:
            x32 = self.down32(x16)
            x16 = x16 + nn.functional.interpolate(self.up32(x32), size=x16.shape[-2:], mode="nearest")
        x8 = x8 + nn.functional.interpolate(self.up16(x16), size=x8.shape[-2:], mode="nearest")
        x4 = x4 + nn.functional.interpolate(self.up8(x8), size=x4.shape[-2:], mode="nearest")
        return self.head(x4)


def decode_grid(raw: Any) -> tuple[Any, Any, Any, Any, Any]:
    """Raw outputs → score (sigmoid), centre x, y and size w, h in input pixels, each N×(H/4)×(W/4)."""
    _, _, gh, gw = raw.shape
    gy = torch.arange(gh, dtype=raw.dtype).view(1, gh, 1)
    gx = torch.arange(gw, dtype=raw.dtype).view(1, 1, gw)
    score = torch.sigmoid(raw[:, 0])
    cx = (gx + torch.sigmoid(raw[:, 1]) * 2.0 - 0.5) * STRIDE
    cy = (gy + torch.sigmoid(raw[:, 2]) * 2.0 - 0.5) * STRIDE
    w = torch.exp(raw[:, 3].clamp(-4.0, 5.0)) * STRIDE
    h = torch.exp(raw[:, 4].clamp(-4.0, 5.0)) * STRIDE
    return score, cx, cy, w, h


class YoloV8Export(nn.Module):  # type: ignore[misc]
    """The network with its decoding, as one graph whose output is the YOLOv8 layout (1, 5, N)."""

    def __init__(self, net: Any) -> None:
        super().__init__()
        self.net = net

    def forward(self, images: Any) -> Any:
        raw = self.net(images)
        score, cx, cy, w, h = decode_grid(raw)
        peak = nn.functional.max_pool2d(score.unsqueeze(1), 3, 1, 1).squeeze(1)
        score = score * (score >= peak).to(score.dtype)
        n = raw.shape[0]
        return torch.stack([cx, cy, w, h, score], dim=1).reshape(n, 5, -1)


__all__ = ["OUTPUTS", "STRIDE", "PersonNet", "YoloV8Export", "decode_grid"]
