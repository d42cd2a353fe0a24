"""The campaign manifest: everything that decides a campaign's records, so it can be repeated — or resumed — exactly.

``manifest.json`` holds the campaign seed, the scenes (their ids and a SHA-256 of each scene's content), the
systems (LLM specs without keys), the episode settings, the package versions (agentic-uavs, numpy, scipy, jsbsim,
pydantic, Python) and a digest of the code the records depend on (the simulated scene and detector, perception,
the reasoners, the prompts, and the episode, record and system modules of this package). A campaign directory is
resumed only under an equal manifest; :func:`manifest_differences` names what differs. ``created_at``, ``workers``,
``executor``, ``job_order_seed`` (derived from the seed) and the scene files' paths are informative and never
compared.

>>> from evaluation.campaign.episode import EpisodeSettings
>>> from evaluation.campaign.systems import SystemSpec
>>> a = build_manifest(seed=0, scenes=[], systems=[SystemSpec(name="rules", kind="rules")],
...                    settings=EpisodeSettings(), scene_source=SceneSource(kind="generated", count=0, seed=0))
>>> b = a.model_copy(update={"settings": EpisodeSettings(frames=60)})
>>> manifest_differences(a, b)
['settings.frames: 360 in the campaign directory, 60 now']
"""

from __future__ import annotations

import hashlib
import importlib
import platform
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from flight.sim.scene_model import Scene

from .episode import EpisodeSettings
from .systems import SystemSpec

MANIFEST_VERSION = 1
PACKAGES = ("agentic-uavs", "numpy", "scipy", "jsbsim", "pydantic")
CODE_MODULES = (
    "flight.camera",
    "flight.sim.scene",
    "flight.sim.scene_model",
    "flight.sim.scene_gen",
    "flight.sim.detector",
    "agentic_core.perception",
    "agentic_core.reasoning",
    "prompts",
    "evaluation.campaign.episode",
    "evaluation.campaign.records",
    "evaluation.campaign.systems",
)
"""The code a record depends on: a package means every ``.py``, ``.md`` and ``.json`` file under it."""
NOT_COMPARED = frozenset({"created_at", "workers", "executor", "job_order_seed"})


class SceneSource(BaseModel):
    """Where the scenes came from: ``generate_scenes(count, seed)`` or scene files (paths: information only)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    kind: Literal["generated", "files"]
    count: int = Field(ge=0)
    seed: int | None = Field(default=None, description="the generator's seed")
    files: list[str] = Field(default_factory=list, description="as given (not compared)")


class SceneEntry(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")

    id: str
    sha256: str = Field(description="of the scene's canonical JSON")
    expected_severity: str


class CampaignManifest(BaseModel):
    """What a campaign is (see the module docs)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    manifest_version: int = MANIFEST_VERSION
    seed: int
    scene_source: SceneSource
    scenes: list[SceneEntry]
    systems: list[SystemSpec]
    settings: EpisodeSettings
    versions: dict[str, str]
    code_sha256: str
    created_at: str = ""
    workers: int = 1
    executor: str = Field(default="", description="where the jobs ran (--executor), informative")
    job_order_seed: int | None = Field(default=None, description="the seed the job order was shuffled with")

    def comparable(self) -> dict[str, Any]:
        """The manifest as JSON data without the informative fields."""
        data = self.model_dump(mode="json", exclude=set(NOT_COMPARED))
        data["scene_source"].pop("files", None)
        return data


def scene_digest(scene: Scene) -> str:
    """SHA-256 of a scene's canonical JSON (equal scenes, equal digests, wherever they came from)."""
    return hashlib.sha256(scene.model_dump_json(by_alias=True).encode("utf-8")).hexdigest()


def package_versions() -> dict[str, str]:
    """The versions of the packages records depend on, and Python's."""
    out = {}
    for package in PACKAGES:
        try:
            out[package] = metadata.version(package)
        except metadata.PackageNotFoundError:
            out[package] = "not installed"
    out["python"] = platform.python_version()
    return out


def code_digest() -> str:
    """SHA-256 over the source of :data:`CODE_MODULES` (relative paths and bytes, in sorted order)."""
    digest = hashlib.sha256()
    for name in CODE_MODULES:
        module = importlib.import_module(name)
        origin = Path(module.__file__ or "")
        files = (
            sorted(p for p in origin.parent.rglob("*") if p.suffix in (".py", ".md", ".json") and p.is_file())
            if origin.name == "__init__.py"
            else [origin]
        )
        for path in files:
            if "__pycache__" in path.parts:
                continue
            digest.update(f"{name}:{path.relative_to(origin.parent).as_posix()}\n".encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()


def build_manifest(
    *,
    seed: int,
    scenes: list[Scene],
    systems: list[SystemSpec],
    settings: EpisodeSettings,
    scene_source: SceneSource,
    workers: int = 1,
) -> CampaignManifest:
    """The manifest of a campaign about to run (versions and code digest read now)."""
    return CampaignManifest(
        seed=seed,
        scene_source=scene_source,
        scenes=[
            SceneEntry(id=s.id, sha256=scene_digest(s), expected_severity=s.ground_truth.expected_severity)
            for s in scenes
        ],
        systems=systems,
        settings=settings,
        versions=package_versions(),
        code_sha256=code_digest(),
        created_at=datetime.now(UTC).isoformat(timespec="seconds"),
        workers=workers,
    )


def manifest_differences(stored: CampaignManifest, current: CampaignManifest, limit: int = 5) -> list[str]:
    """What differs between a directory's manifest and the one asked for now, setting by setting (at most
    ``limit`` lines); empty when the campaign may be resumed."""
    out: list[str] = []
    _diff(stored.comparable(), current.comparable(), "", out)
    return out[:limit]


def _diff(a: Any, b: Any, path: str, out: list[str]) -> None:
    if isinstance(a, dict) and isinstance(b, dict):
        for key in list(dict.fromkeys([*a, *b])):
            _diff(a.get(key), b.get(key), f"{path}.{key}" if path else str(key), out)
        return
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _diff(x, y, f"{path}[{i}]", out)
        return
    if a != b and path == "code_sha256":
        out.append("code_sha256: the scene, detector, perception, reasoning, prompt or episode code has changed")
    elif a != b:
        out.append(f"{path}: {_show(a)} in the campaign directory, {_show(b)} now")


def _show(value: Any) -> str:
    if isinstance(value, list):
        return f"{len(value)} entries [{', '.join(_show(v) for v in value[:4])}{', ...' if len(value) > 4 else ''}]"
    if isinstance(value, dict):
        return str(value.get("id") or value.get("name") or "{...}")
    text = repr(value)
    return text if len(text) <= 70 else text[:67] + "..."


def load_manifest(path: Path) -> CampaignManifest:
    """Read ``manifest.json``; raises ``ValueError`` naming the file when it is not a campaign manifest."""
    try:
        return CampaignManifest.model_validate_json(path.read_bytes())
    except OSError as exc:
        raise ValueError(f"{path}: cannot read the manifest ({exc.strerror or exc})") from None
    except ValueError as exc:
        raise ValueError(f"{path}: not a campaign manifest ({str(exc).splitlines()[0]})") from None


__all__ = [
    "CODE_MODULES",
    "CampaignManifest",
    "SceneEntry",
    "SceneSource",
    "build_manifest",
    "code_digest",
    "load_manifest",
    "manifest_differences",
    "package_versions",
    "scene_digest",
]
