"""The camera's contracts: what the camera is (CameraSpec), where it is (CameraPose), the frames it takes (Frame)
and what a detector finds in them (Detection, BoundingBox), and the Detector protocol a real model implements.

>>> d = Detection.model_validate({"class": "person", "box": {"x_min": 1, "y_min": 2, "x_max": 5, "y_max": 9},
...                               "confidence": 0.8})
>>> d.class_name, d.box.center
('person', (3.0, 5.5))
>>> Frame(index=0, time_s=0.0, spec=CameraSpec(), pose=CameraPose(north_m=0, east_m=0, down_m=-30)).image is None
True
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

from pydantic import BaseModel, ConfigDict, Field, model_validator
from pydantic.json_schema import SkipJsonSchema

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray


class CameraSpec(BaseModel):
    """What the camera is: field of view, resolution, frame rate and how its gimbal points it.

    The defaults are a typical small-drone camera (84° horizontal field of view, 1920×1080 at 30 Hz) looking
    straight down from a stabilised gimbal, as a search pattern flies it.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    hfov_deg: float = Field(default=84.0, gt=1.0, lt=179.0, description="horizontal field of view")
    width_px: int = Field(default=1920, ge=16)
    height_px: int = Field(default=1080, ge=16)
    rate_hz: float = Field(default=30.0, gt=0.0, description="frames per second")
    gimbal_pitch_deg: float = Field(default=-90.0, ge=-90.0, le=30.0, description="-90 looks straight down")
    stabilized: bool = Field(default=True, description="the gimbal cancels the aircraft's roll and pitch")

    @property
    def focal_px(self) -> float:
        """Focal length in pixels (square pixels)."""
        return (self.width_px / 2.0) / math.tan(math.radians(self.hfov_deg) / 2.0)

    @property
    def vfov_deg(self) -> float:
        """Vertical field of view, from the horizontal one and the aspect ratio."""
        return math.degrees(2.0 * math.atan((self.height_px / 2.0) / self.focal_px))

    @property
    def principal_point(self) -> tuple[float, float]:
        """The image centre (pixels)."""
        return self.width_px / 2.0, self.height_px / 2.0

    @property
    def frame_period_s(self) -> float:
        return 1.0 / self.rate_hz


class CameraPose(BaseModel):
    """Where the camera is and which way the aircraft carrying it faces (local NED metres, radians)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    north_m: float
    east_m: float
    down_m: float = Field(description="negative above home: 30 m up is -30")
    roll_rad: float = 0.0
    pitch_rad: float = 0.0
    yaw_rad: float = Field(default=0.0, description="heading, 0 north, clockwise")

    @property
    def position(self) -> NDArray[np.float64]:
        """The camera's (north, east, down) as an array."""
        import numpy as np

        return np.array([self.north_m, self.east_m, self.down_m])


class SensorHealth(BaseModel):
    """How well the sensors behind a frame are doing; perception inflates its covariances accordingly.

    ``degraded`` names the sensors in trouble (``"gps"``, ``"thermal"``, ``"camera"``), each with a factor >= 1 by
    which that sensor's noise grows (``{"gps": 4.0}``: GPS errors four times their nominal size).
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    degraded: dict[str, float] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _factors_at_least_one(self) -> SensorHealth:
        bad = [name for name, factor in self.degraded.items() if not factor >= 1.0]
        if bad:
            raise ValueError(f"degradation factors must be >= 1: {', '.join(bad)}")
        return self

    def factor(self, sensor: str) -> float:
        """The noise factor of one sensor, 1.0 when it is healthy."""
        return self.degraded.get(sensor, 1.0)

    @property
    def ok(self) -> bool:
        return not self.degraded


class BoundingBox(BaseModel):
    """An axis-aligned pixel box; ``x`` grows rightwards and ``y`` downwards from the image's top-left corner."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    x_min: float
    y_min: float
    x_max: float
    y_max: float

    @model_validator(mode="after")
    def _ordered(self) -> BoundingBox:
        if not (self.x_min <= self.x_max and self.y_min <= self.y_max):
            raise ValueError(f"box corners out of order: ({self.x_min}, {self.y_min}) ({self.x_max}, {self.y_max})")
        return self

    @property
    def center(self) -> tuple[float, float]:
        return (self.x_min + self.x_max) / 2.0, (self.y_min + self.y_max) / 2.0

    @property
    def width(self) -> float:
        return self.x_max - self.x_min

    @property
    def height(self) -> float:
        return self.y_max - self.y_min


class Detection(BaseModel):
    """One object a detector found in one frame: its class, pixel box and confidence.

    ``truth_id`` is the simulated actor the detection came from (``None`` for a false positive or a real
    detector); it exists only so evaluation can score against ground truth, and perception never reads it.
    """

    model_config = ConfigDict(frozen=True, extra="forbid", populate_by_name=True)

    class_name: str = Field(alias="class", description="person, vehicle, ...")
    box: BoundingBox
    confidence: float = Field(ge=0.0, le=1.0)
    truth_id: str | None = None


class Frame(BaseModel):
    """One camera frame: when and from where it was taken, the sensors' health, and the image if there is one.

    The statistical simulated camera gives no pixels (``image`` is ``None``); the rendering camera (``--render``,
    ``--detector ours|onnx:PATH``) and a real one do, and a real detector reads ``image`` (H×W×3, uint8), which
    stays out of the JSON form.
    """

    model_config = ConfigDict(frozen=True, extra="forbid", arbitrary_types_allowed=True)

    index: int = Field(ge=0)
    time_s: float
    spec: CameraSpec
    pose: CameraPose
    health: SensorHealth = Field(default_factory=SensorHealth)
    image: SkipJsonSchema[Any] = Field(default=None, exclude=True, description="H×W×3 uint8 pixels, or None")


@runtime_checkable
class Detector(Protocol):
    """Anything that turns a frame into detections: the simulated detector, or a real model the user plugs in."""

    def detect(self, frame: Frame) -> list[Detection]: ...


def detection_json_schema() -> dict[str, Any]:
    """The JSON Schema of one :class:`Detection` (``class`` spelt as on the wire)."""
    return Detection.model_json_schema(by_alias=True)


def frame_json_schema() -> dict[str, Any]:
    """The JSON Schema of a :class:`Frame`'s metadata (the image is not part of it)."""
    return Frame.model_json_schema(by_alias=True)


__all__ = [
    "BoundingBox",
    "CameraPose",
    "CameraSpec",
    "Detection",
    "Detector",
    "Frame",
    "SensorHealth",
    "detection_json_schema",
    "frame_json_schema",
]
