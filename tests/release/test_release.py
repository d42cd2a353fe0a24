"""The release check: build the sdist and wheel, check their metadata, install the wheel into a fresh virtual
environment outside the repository and fly the emergency mission by name from an empty working directory.

Kept cheap: the build runs without isolation (setuptools and build come with the dev extra), the fresh venv has no
pip, and the wheel is installed without its dependencies, which the new venv sees through a ``.pth`` file naming
this interpreter's site-packages (a path line there does not run that folder's own ``.pth`` files, so an editable
install of the checkout does not leak in; the test asserts the package imported is the wheel's). The flight is the
emergency mission by name over its shipped scene (found by name too), one round, with a 5 Hz camera (as the
shipped-missions tests fly it). Select it with ``-m release``.
"""

from __future__ import annotations

import json
import os
import resource
import shutil
import subprocess
import sys
import sysconfig
import tarfile
import time
import zipfile
from pathlib import Path
from typing import Any

import pytest

import agentic_core

from .notice import PACKAGES, package_files, problems

ROOT = Path(__file__).resolve().parents[2]
BUILD_INPUTS = ("pyproject.toml", "README.md", "LICENSE", "NOTICE", *PACKAGES, "missions", "scenes")
"""What the build reads: the packages, their metadata files, and the folders the examples link to."""

MAIL_SETTINGS = ("AGENTIC_UAV_SMTP_", "AGENTIC_UAV_ALERT_RECIPIENTS")
"""The test's own mail server (the ``smtp`` fixture), the one setting the installed run is given."""

pytestmark = [pytest.mark.release, pytest.mark.slow, pytest.mark.timeout(900)]


def _env() -> dict[str, str]:
    """This environment without anything that would point Python at the checkout or the run at real servers."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "AGENTIC_UAV_")) and k != "VIRTUAL_ENV"}
    return env | {"PYTHONNOUSERSITE": "1"}


def _run(*argv: str | Path, cwd: Path, timeout_s: float = 600.0, env: dict[str, str] | None = None) -> str:
    done = subprocess.run(
        [str(a) for a in argv], cwd=cwd, env=_env() | (env or {}), capture_output=True, text=True,
        timeout=timeout_s, check=False,
    )  # fmt: skip
    assert done.returncode == 0, f"{argv} exited {done.returncode}:\n{done.stdout}\n{done.stderr}"
    return done.stdout


def _copy_sources(dest: Path) -> None:
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    for name in BUILD_INPUTS:
        source = ROOT / name
        if source.is_dir():
            shutil.copytree(source, dest / name, symlinks=True, ignore=ignore)
        else:
            shutil.copy2(source, dest / name)


class Clock:
    """How long each phase took, printed at the end (``pytest -s`` shows it; a failure's report does too)."""

    def __init__(self) -> None:
        self.start = self.last = time.monotonic()
        self.cpu_start = self.cpu_last = self._cpu()
        self.phases: list[str] = []

    @staticmethod
    def _cpu() -> float:
        used = resource.getrusage(resource.RUSAGE_CHILDREN)
        return used.ru_utime + used.ru_stime

    def lap(self, name: str) -> None:
        now, cpu = time.monotonic(), self._cpu()
        self.phases.append(f"{name} {now - self.last:.1f}s ({cpu - self.cpu_last:.1f}s CPU)")
        self.last, self.cpu_last = now, cpu

    def __str__(self) -> str:
        total = f"{time.monotonic() - self.start:.1f}s, {self._cpu() - self.cpu_start:.1f}s CPU in subprocesses"
        return f"release check {total}: " + ", ".join(self.phases)


@pytest.mark.slow
def test_the_wheel_installs_in_a_fresh_venv_and_flies_the_emergency_mission_by_name(tmp_path: Path, smtp: Any) -> None:
    clock = Clock()
    source, dist, venv, work = (tmp_path / name for name in ("source", "dist", "venv", "work"))
    for folder in (source, work):
        folder.mkdir()
    _copy_sources(source)
    _run(sys.executable, "-m", "build", "--no-isolation", "--outdir", dist, source, cwd=tmp_path)
    (wheel,) = dist.glob("*.whl")
    (sdist,) = dist.glob("*.tar.gz")
    clock.lap("build")
    _run(sys.executable, "-m", "twine", "check", "--strict", wheel, sdist, cwd=tmp_path)
    clock.lap("twine check")

    # the wheel: licence and notice, every file of the packages, nothing unlisted in NOTICE, one version
    version = agentic_core.__version__
    info = f"agentic_uavs-{version}.dist-info"
    with zipfile.ZipFile(wheel) as archive:
        names = set(archive.namelist())
        for name in ("LICENSE", "NOTICE"):
            assert archive.read(f"{info}/licenses/{name}") == (ROOT / name).read_bytes()
        metadata = archive.read(f"{info}/METADATA").decode()
    assert f"\nVersion: {version}\n" in metadata and "\nLicense-Expression: Apache-2.0\n" in metadata
    assert "\nLicense-File: LICENSE\n" in metadata and "\nLicense-File: NOTICE\n" in metadata
    packaged = sorted(n for n in names if not n.startswith(info))
    assert sorted(set(package_files(source)) - set(packaged)) == []  # every file of the checkout's packages
    assert problems(packaged, (ROOT / "NOTICE").read_text(encoding="utf-8")) == []
    with tarfile.open(sdist) as archive:
        members = {m.name.partition("/")[2]: m for m in archive.getmembers()}
    for name in ("LICENSE", "NOTICE", "agentic_core/examples/missions/hajj_emergency.yaml"):
        assert members[name].isfile(), name
    clock.lap("contents")

    # a fresh venv outside the repository, the wheel alone installed; the dependencies seen through a .pth file
    _run(sys.executable, "-m", "venv", "--without-pip", venv, cwd=tmp_path)
    python = venv / "bin" / "python"
    _run(sys.executable, "-m", "pip", "--python", python, "install", "--quiet", "--no-deps", "--no-index",
         "--no-cache-dir", "--disable-pip-version-check", wheel, cwd=tmp_path)  # fmt: skip
    site = Path(_run(python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])", cwd=work).strip())
    ours = sysconfig.get_paths()
    (site / "release_check_dependencies.pth").write_text("\n".join(dict.fromkeys([ours["purelib"], ours["platlib"]])))
    clock.lap("venv and install")

    probe = (
        "import json, agentic_core, importlib.metadata as md\n"
        "from agentic_core.examples import mission_path\n"
        "from agentic_core.run.settings import default_scene\n"
        "m = mission_path('hajj_emergency')\n"
        "print(json.dumps({'package': agentic_core.__file__, 'version': agentic_core.__version__,\n"
        "                  'installed': md.version('agentic-uavs'), 'mission': str(m),\n"
        "                  'scene': str(default_scene(m))}))"
    )
    seen = json.loads(_run(python, "-c", probe, cwd=work))
    for key in ("package", "mission", "scene"):
        assert Path(seen[key]).is_relative_to(site), (key, seen[key])  # the wheel's files, not the checkout's
    assert Path(seen["scene"]).name == "hajj_emergency.yaml"
    assert seen["version"] == seen["installed"] == version
    cli = venv / "bin" / "agentic-uav"
    assert _run(cli, "--version", cwd=work) == f"agentic-uavs {version}\n"
    _run(cli, "examples", "copy", "mine", cwd=work)
    assert (work / "mine" / "missions" / "hajj_emergency.yaml").read_bytes() == Path(seen["mission"]).read_bytes()
    clock.lap("probes")

    out = _run(cli, "run", "hajj_emergency", "--param", "rounds=1", "--camera-hz", "5",
               "--runs-dir", "runs", "--quiet", cwd=work,
               env={k: v for k, v in os.environ.items() if k.startswith(MAIL_SETTINGS)})  # fmt: skip
    clock.lap("flight")
    assert ": completed: " in out or ": returned: " in out, out  # the alert went out by SMTP: not degraded
    assert len(smtp.inbox.envelopes) == 1
    (run_dir,) = (work / "runs").iterdir()
    settings = json.loads((run_dir / "run.json").read_text())["settings"]
    assert Path(settings["mission"]).is_relative_to(site) and settings["scene"] is None  # the shipped scene, by name
    assert "over scene `hajj-emergency`" in (run_dir / "report.md").read_text()
    trace = [json.loads(line) for line in (run_dir / "trace.jsonl").read_text().splitlines()]
    done = [r["name"] for r in trace if r["kind"] == "tool" and r.get("status") == "ok"]
    for tool in ("alerts.notify", "flight.land", "flight.deploy_payload"):
        assert tool in done, (tool, done)
    assert (run_dir / "report.md").is_file()
    print(clock)
