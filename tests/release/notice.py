"""NOTICE's list of vendored files and shipped weights, and the files of a package tree that it must list.

A file is the project's own when it is Python, Markdown, JSON or YAML (or a ``py.typed`` marker) and lies under no
vendor folder; any other file the distribution carries (a model's weights, a JavaScript library, a font) must be
listed in NOTICE with its licence and source.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path, PurePosixPath

HEADING = "Vendored files and shipped weights"
PACKAGES = ("agentic_core", "tools", "flight", "evaluation", "prompts")
OUR_KINDS = {".py", ".pyi", ".md", ".json", ".yaml", ".yml"}
VENDOR_FOLDERS = {"vendor", "_vendor", "vendored", "third_party", "weights"}


def listed(notice: str) -> dict[str, tuple[str, str]]:
    """The files NOTICE lists under its heading: path → (licence, source); ValueError naming a malformed line."""
    lines = notice.splitlines()
    if HEADING not in lines:
        raise ValueError(f"NOTICE has no {HEADING!r} section")
    entries: dict[str, tuple[str, str]] = {}
    for number, line in enumerate(lines[lines.index(HEADING) + 1 :], start=lines.index(HEADING) + 2):
        if "|" not in line:
            continue
        fields = [field.strip() for field in line.split("|")]
        if len(fields) != 3 or not all(fields):
            raise ValueError(f"NOTICE:{number}: want 'path | licence | source', got {line!r}")
        entries[fields[0]] = (fields[1], fields[2])
    return entries


def ours(path: str) -> bool:
    """Whether a file (a path inside the distribution) is of a kind the project writes itself."""
    p = PurePosixPath(path)
    if VENDOR_FOLDERS & set(p.parts[:-1]):
        return False
    return p.name == "py.typed" or p.suffix in OUR_KINDS


def package_files(root: Path) -> list[str]:
    """Every file of the project's packages under ``root`` (a checkout or an unpacked wheel), as posix paths
    relative to it; compiled bytecode left out. Linked folders are followed, as the build follows them."""
    found: list[str] = []
    for package in PACKAGES:
        for folder, dirs, names in os.walk(root / package, followlinks=True):
            dirs[:] = [d for d in dirs if d != "__pycache__"]
            found += [Path(folder, n).relative_to(root).as_posix() for n in names if not n.endswith(".pyc")]
    return sorted(found)


def problems(files: Iterable[str], notice: str) -> list[str]:
    """What is wrong between ``files`` and NOTICE: a file not ours and not listed, a listed file that is absent."""
    entries, present = listed(notice), set(files)
    unlisted = [f"{f}: not the project's own kind of file and not listed in NOTICE" for f in sorted(present)
                if not ours(f) and f not in entries]  # fmt: skip
    stale = [f"{f}: listed in NOTICE but not in the distribution" for f in sorted(entries) if f not in present]
    return unlisted + stale
