"""The camera that renders pixels: a scene as an RGB frame seen from the aircraft's camera, with exact labels.

Modules of one job each: :mod:`.texture` (periodic noise), :mod:`.palette` (colours), :mod:`.ground_tiles` (the
ground's look from zones and landmarks, tile by tile), :mod:`.ground` (the ground through the camera),
:mod:`.bodies` (people and vehicles as shapes in the world), :mod:`.raster` (shapes into pixels), :mod:`.sensor`
(blur and noise), :mod:`.renderer` (the frame's assembly), :mod:`.dataset` (labelled frames for training),
:mod:`.orthophoto` (the ground straight down over a whole scene), :mod:`.png` (an image as PNG bytes).

>>> from flight.sim.render import SceneRenderer
>>> SceneRenderer.__name__
'SceneRenderer'
"""

from __future__ import annotations

from .renderer import PersonView, Rendered, SceneRenderer

__all__ = ["PersonView", "Rendered", "SceneRenderer"]
