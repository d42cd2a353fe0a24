"""JSBSim's aircraft are found beside the jsbsim module wherever it was installed, not only in site-packages
(jsbsim's own lookup fails for an install seen through PYTHONPATH or a .pth line, as in the release check)."""

from __future__ import annotations

from pathlib import Path
from typing import NoReturn

import jsbsim
import pytest

from flight.sim.jsbsim_model import F450Model, jsbsim_root_dir


def _lost() -> NoReturn:
    raise OSError("Can't find the default root directory")


def test_the_f450_loads_when_jsbsims_own_lookup_fails(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(jsbsim, "get_default_root_dir", _lost)
    assert Path(jsbsim_root_dir(), "aircraft", "F450").is_dir()
    model = F450Model(21.4133, 39.8933, 300.0)
    assert model.home_alt_msl_m == 300.0


def test_jsbsims_lookup_is_the_fallback_when_its_folder_has_no_aircraft(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(jsbsim, "__file__", str(tmp_path / "__init__.py"))
    monkeypatch.setattr(jsbsim, "get_default_root_dir", lambda: "/the/default/root")
    assert jsbsim_root_dir() == "/the/default/root"
    monkeypatch.setattr(jsbsim, "get_default_root_dir", _lost)
    with pytest.raises(OSError, match="default root"):
        jsbsim_root_dir()
