"""LICENSE and NOTICE: the Apache-2.0 text, and every file of the packages that is not ours listed in NOTICE."""

from __future__ import annotations

from pathlib import Path

import pytest

from .notice import listed, ours, package_files, problems

ROOT = Path(__file__).resolve().parents[2]


def test_the_licence_is_the_apache_2_text_pyproject_declares() -> None:
    text = (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert "Apache License" in text and "Version 2.0, January 2004" in text
    assert "END OF TERMS AND CONDITIONS" in text and "APPENDIX: How to apply the Apache License" in text
    assert 'license = "Apache-2.0"' in (ROOT / "pyproject.toml").read_text(encoding="utf-8")


def test_every_file_of_the_packages_that_is_not_ours_is_listed_in_notice() -> None:
    files = package_files(ROOT)
    assert "agentic_core/examples/missions/hajj_emergency.yaml" in files  # the walk follows the examples' links
    assert problems(files, (ROOT / "NOTICE").read_text(encoding="utf-8")) == []


@pytest.mark.parametrize(
    "path",
    [
        "flight/sim/weights/detector.onnx",
        "agentic_core/console/static/leaflet.js",
        "agentic_core/console/vendor/leaflet/leaflet.json",  # a kind of ours, but under a vendor folder
        "agentic_core/perception/person.safetensors",
        "tools/LICENSE",
    ],
)
def test_a_file_that_is_not_ours_and_not_listed_is_caught(path: str) -> None:
    notice = (ROOT / "NOTICE").read_text(encoding="utf-8")
    assert not ours(path)
    present = ["agentic_core/cli.py", *listed(notice), path]  # what NOTICE lists already is there
    assert problems(present, notice) == [f"{path}: not the project's own kind of file and not listed in NOTICE"]
    listing = f"{notice}\n{path} | MIT | https://example.org/source\n"
    assert problems(present, listing) == []


def test_a_listed_file_the_distribution_lacks_is_caught_and_a_bad_line_is_named() -> None:
    notice = (ROOT / "NOTICE").read_text(encoding="utf-8")
    stale = f"{notice}\nflight/gone.onnx | Apache-2.0 | trained here\n"
    assert listed(stale) == {**listed(notice), "flight/gone.onnx": ("Apache-2.0", "trained here")}
    assert problems(["agentic_core/cli.py", *listed(notice)], stale) == [
        "flight/gone.onnx: listed in NOTICE but not in the distribution"
    ]
    lines = len(notice.splitlines())
    with pytest.raises(ValueError, match=rf"NOTICE:{lines + 2}: want 'path \| licence \| source'"):
        listed(f"{notice}\nflight/x.onnx | MIT\n")
    with pytest.raises(ValueError, match="no 'Vendored files and shipped weights' section"):
        listed("agentic-uavs\n")


def test_the_walk_sees_files_of_every_kind(tmp_path: Path) -> None:
    (tmp_path / "flight" / "sim" / "__pycache__").mkdir(parents=True)
    (tmp_path / "flight" / "sim" / "__pycache__" / "x.cpython-311.pyc").write_bytes(b"")
    (tmp_path / "flight" / "sim" / "model.onnx").write_bytes(b"\0")
    (tmp_path / "flight" / "py.typed").write_text("")
    assert package_files(tmp_path) == ["flight/py.typed", "flight/sim/model.onnx"]
