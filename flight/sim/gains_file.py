"""Position-controller gains from a file: the ``tune.json`` that ``agentic-uav eval tune`` writes, or a plain object.

Only the horizontal gains the tuner adjusts can be set, each inside its safe range (:data:`TUNABLE`: outside it the
F450 oscillates or crawls); the others keep their defaults. ``tune.json``'s ``gains`` are the accepted candidate's
when the held-out flights accepted it, else the incumbent's, so flying with the file is flying what was accepted.

>>> import json, tempfile
>>> with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
...     json.dump({"gains": {"pos_xy": 0.9, "vel_xy_p": 2.8}}, f)
>>> g = load_gains(f.name)
>>> g.pos_xy, g.vel_xy_p, g.vel_xy_i
(0.9, 2.8, 0.4)
"""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

from agentic_core.contracts.errors import InputError
from flight.sim.controller import Gains

TUNABLE: dict[str, tuple[float, float]] = {
    "pos_xy": (0.3, 1.6),
    "vel_xy_p": (1.0, 4.5),
    "vel_xy_i": (0.0, 1.0),
    "vel_xy_d": (0.0, 0.3),
}
"""The gains a file may set, and the safe range of each (inclusive)."""

MAX_BYTES = 1 << 20


class GainsFileError(InputError):
    """A gains file that cannot be read, or that asks for a gain we do not tune or one outside its safe range."""


def load_gains(path: str | Path, base: Gains | None = None) -> Gains:
    """``base`` (the defaults) with the gains ``path`` sets; :class:`GainsFileError` naming the file and the field."""
    where = Path(path)
    try:
        if where.stat().st_size > MAX_BYTES:
            raise GainsFileError(f"{where}: larger than {MAX_BYTES} bytes; not a gains file")
        data = json.loads(where.read_text(encoding="utf-8"))
    except OSError as exc:
        raise GainsFileError(f"{where}: cannot read the gains file ({exc.strerror or exc})") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise GainsFileError(f"{where}: not JSON ({exc})") from None
    values = data.get("gains", data) if isinstance(data, dict) else None
    if not isinstance(values, dict) or not values:
        raise GainsFileError(f"{where}: expected an object of gains (or tune.json's 'gains'), e.g. {{\"pos_xy\": 0.9}}")
    field = "gains." if "gains" in data else ""
    chosen: dict[str, float] = {}
    for name, value in values.items():
        if name not in TUNABLE:
            raise GainsFileError(f"{where}: {field}{name}: not a tunable gain; one of {', '.join(TUNABLE)}")
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
            raise GainsFileError(f"{where}: {field}{name}: expected a finite number, got {value!r}")
        low, high = TUNABLE[name]
        if not low <= value <= high:
            raise GainsFileError(f"{where}: {field}{name}: {value:g} is outside its safe range {low:g} to {high:g}")
        chosen[name] = float(value)
    return replace(base or Gains(), **chosen)


__all__ = ["TUNABLE", "GainsFileError", "load_gains"]
