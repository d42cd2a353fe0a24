"""The simulated camera with pixels: :class:`RenderingCamera` takes frames as
:class:`~flight.sim.detector.SimulatedCamera` does and fills each frame's ``image`` with the rendered view.

:func:`render_spec` is the camera a run with rendering uses: 640×480, the default camera's 84° field of view and
gimbal. Give the camera the :class:`~flight.sim.scene.SceneState` the simulated detector moves, so both see the
scene at the same moment.

>>> from flight.sim.scene_file import load_scene
>>> from agentic_core.contracts.camera import CameraPose
>>> camera = RenderingCamera(SceneRenderer(load_scene("scenes/hajj_emergency.yaml")), render_spec())
>>> frame = camera.capture(CameraPose(north_m=150.0, east_m=0.0, down_m=-30.0), time_s=0.0)
>>> frame.image.shape, frame.spec.width_px
((480, 640, 3), 640)
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from agentic_core.contracts.camera import CameraPose, CameraSpec, Frame, SensorHealth
from flight.sim.detector import SimulatedCamera
from flight.sim.scene import SceneState

from .renderer import SceneRenderer

if TYPE_CHECKING:
    from flight.sim.simulator import VehicleState

RENDER_WIDTH_PX = 640
RENDER_HEIGHT_PX = 480


def render_spec(rate_hz: float = 30.0) -> CameraSpec:
    """The rendering camera: 640×480 at ``rate_hz``, otherwise the default camera."""
    return CameraSpec(width_px=RENDER_WIDTH_PX, height_px=RENDER_HEIGHT_PX, rate_hz=rate_hz)


class RenderingCamera(SimulatedCamera):
    """A :class:`SimulatedCamera` whose frames carry rendered pixels (blurred by the vehicle's velocity when
    captured from a vehicle state)."""

    def __init__(
        self,
        renderer: SceneRenderer,
        spec: CameraSpec | None = None,
        health: SensorHealth | Callable[[float], SensorHealth] | None = None,
    ) -> None:
        super().__init__(spec or render_spec(), health)
        self.renderer = renderer

    def capture(self, source: VehicleState | CameraPose, time_s: float | None = None) -> Frame:
        frame = super().capture(source, time_s)
        velocity = (0.0, 0.0, 0.0) if isinstance(source, CameraPose) else (source.vn_mps, source.ve_mps, source.vd_mps)
        image = self.renderer.render_frame(frame, velocity).image
        return frame.model_copy(update={"image": image})


def rendering_camera(state: SceneState, seed: int = 0, like: SimulatedCamera | None = None) -> RenderingCamera:
    """A rendering camera over ``state`` (shared with the simulated detector), at the frame rate and sensor health
    of the camera it stands in for (``like``)."""
    rate = like.spec.rate_hz if like is not None else 30.0
    return RenderingCamera(SceneRenderer(state, seed=seed), render_spec(rate), like.health if like else None)


__all__ = ["RENDER_HEIGHT_PX", "RENDER_WIDTH_PX", "RenderingCamera", "render_spec", "rendering_camera"]
