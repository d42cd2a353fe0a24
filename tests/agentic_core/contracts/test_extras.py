"""An optional module imported through the extras helper: present, it is returned; missing (or missing something
it needs), the error names the extra to install and exits 2 with one line; an extra nobody declared is refused."""

from __future__ import annotations

import io
import sys
from pathlib import Path

import pytest

from agentic_core.contracts import InputError, report_error
from agentic_core.contracts.extras import EXTRAS, MissingExtra, install_hint, require

KNOWN = {"console": "the operator console"}


def test_an_installed_module_is_imported_and_returned() -> None:
    assert require("json", "console", extras=KNOWN) is sys.modules["json"]


def test_a_missing_module_names_the_extra_that_installs_it() -> None:
    with pytest.raises(MissingExtra) as caught:
        require("agentic_uavs_no_such_module", "console", extras=KNOWN)
    error = caught.value
    assert isinstance(error, InputError) and error.exit_status == 2
    assert (error.extra, error.module) == ("console", "agentic_uavs_no_such_module")
    assert str(error).startswith("the operator console needs agentic_uavs_no_such_module (")
    assert str(error).endswith(": pip install 'agentic-uavs[console]'")
    out = io.StringIO()
    assert report_error("agentic-uav console", error, out) == 2
    assert out.getvalue().count("\n") == 1 and "Traceback" not in out.getvalue()


def test_a_module_whose_own_dependency_is_missing_still_names_the_extra(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "agentic_uavs_half_installed.py").write_text("import agentic_uavs_its_missing_dependency\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(MissingExtra, match=r"agentic_uavs_its_missing_dependency.*\[console\]'$"):
        require("agentic_uavs_half_installed", "console", extras=KNOWN)


def test_a_module_that_fails_to_import_otherwise_is_not_hidden(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "agentic_uavs_broken.py").write_text("raise RuntimeError('a bug in the module, not a missing extra')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(RuntimeError, match="a bug in the module"):
        require("agentic_uavs_broken", "console", extras=KNOWN)


def test_an_extra_that_is_not_declared_is_refused_before_importing() -> None:
    with pytest.raises(KeyError, match="'gpu' is not an extra of agentic-uavs"):
        require("json", "gpu", extras=KNOWN)
    with pytest.raises(KeyError, match=r"known: none" if not EXTRAS else r"known: "):
        require("json", "no-such-extra")


def test_the_hint_is_quoted_for_the_shell() -> None:
    assert install_hint("train") == "pip install 'agentic-uavs[train]'"
