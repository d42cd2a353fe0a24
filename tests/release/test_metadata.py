"""The version comes from one place, CHANGELOG.md has a section per version, and the extras helper knows exactly
the extras pyproject.toml declares."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path
from typing import Any

import pytest
from packaging.version import Version

import agentic_core
from agentic_core.contracts.extras import EXTRAS

ROOT = Path(__file__).resolve().parents[2]
HEADING = re.compile(r"^## \[(?P<name>[^\]]+)\](?: - (?P<date>\d{4}-\d{2}-\d{2}))?$")


def _pyproject() -> dict[str, Any]:
    return tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))


def test_the_version_is_written_once_in_agentic_core() -> None:
    project = _pyproject()
    assert "version" not in project["project"] and "version" in project["project"]["dynamic"]
    assert project["tool"]["setuptools"]["dynamic"]["version"] == {"attr": "agentic_core.__version__"}
    assert str(Version(agentic_core.__version__)) == agentic_core.__version__  # a canonical PEP 440 version


def sections(changelog: str) -> list[tuple[str, str | None]]:
    """The changelog's ``## [name] - date`` headings in order; ValueError naming a heading of another shape."""
    found = []
    for number, line in enumerate(changelog.splitlines(), start=1):
        if line.startswith("## "):
            match = HEADING.match(line)
            if match is None:
                raise ValueError(f"CHANGELOG.md:{number}: want '## [Unreleased]' or '## [X.Y.Z] - YYYY-MM-DD'")
            found.append((match["name"], match["date"]))
    return found


def version_problems(changelog: str, version: str) -> list[str]:
    """What breaks 'a section per version': Unreleased first, then dated releases, newest first, the current
    version among them unless it is still a development or pre-release."""
    heads = sections(changelog)
    problems = [] if heads[:1] == [("Unreleased", None)] else ["the first section is not '## [Unreleased]'"]
    releases = heads[1:]
    problems += [f"[{name}]: a release section needs a date" for name, date in releases if date is None]
    versions = [Version(name) for name, _ in releases]
    if versions != sorted(versions, reverse=True) or len(set(versions)) != len(versions):
        problems.append("the release sections are not newest first, each once")
    current = Version(version)
    if not (current.is_devrelease or current.is_prerelease) and current not in versions:
        problems.append(f"the released version {version} has no section")
    return problems


def test_the_changelog_has_unreleased_first_and_a_section_per_version() -> None:
    assert version_problems((ROOT / "CHANGELOG.md").read_text(encoding="utf-8"), agentic_core.__version__) == []


@pytest.mark.parametrize(
    ("changelog", "version", "problem"),
    [
        ("## [0.1.0] - 2025-01-01\n", "0.1.0", "the first section is not '## [Unreleased]'"),
        ("## [Unreleased]\n## [0.1.0]\n", "0.1.0", "[0.1.0]: a release section needs a date"),
        ("## [Unreleased]\n## [0.1.0] - 2025-01-01\n## [0.2.0] - 2025-02-01\n", "0.2.0", "not newest first"),
        ("## [Unreleased]\n## [0.1.0] - 2025-01-01\n", "0.2.0", "the released version 0.2.0 has no section"),
    ],
)
def test_a_changelog_out_of_shape_is_caught(changelog: str, version: str, problem: str) -> None:
    assert any(problem in p for p in version_problems(changelog, version))


def test_a_heading_of_another_shape_is_named_by_line() -> None:
    with pytest.raises(ValueError, match=r"CHANGELOG.md:2: want"):
        sections("## [Unreleased]\n## Version 0.1\n")
    assert version_problems("## [Unreleased]\n## [0.1.0] - 2025-01-01\n", "0.2.0.dev0") == []


def test_the_extras_helper_knows_exactly_the_extras_pyproject_declares() -> None:
    declared = set(_pyproject()["project"]["optional-dependencies"]) - {"dev"}
    assert set(EXTRAS) == declared
    assert all(EXTRAS.values()), "every extra says what it enables"
