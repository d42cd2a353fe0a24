"""The shipped missions and scenes: the package's view is the repository's folders, a name finds a mission and its
scene, paths keep working, ``agentic-uav examples`` lists them and ``examples copy`` never overwrites unasked."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from agentic_core.cli import main
from agentic_core.examples import (
    ExampleError,
    copy_examples,
    mission_path,
    resolve_mission,
    resolve_scene,
    scene_path,
    shipped_missions,
    shipped_scenes,
)
from agentic_core.run.settings import default_scene

REPO = Path(__file__).resolve().parents[2]
PACKAGED = REPO / "agentic_core" / "examples"


def _stems(folder: Path) -> list[str]:
    """The missions or scenes under ``folder``, those at its top first (as ``agentic-uav examples`` lists them)."""
    found = [p for p in folder.rglob("*.yaml")]
    return [p.stem for p in sorted(found, key=lambda p: (len(p.relative_to(folder).parts), p.name))]


def test_the_package_ships_exactly_the_repositorys_missions_and_scenes() -> None:
    for kind in ("missions", "scenes"):
        assert (PACKAGED / kind).resolve() == (REPO / kind).resolve()
    assert [m.name for m in shipped_missions()] == _stems(REPO / "missions")
    assert [s.name for s in shipped_scenes()] == _stems(REPO / "scenes")
    assert "hajj_emergency" in _stems(REPO / "missions")


def test_a_name_finds_the_shipped_mission_and_its_scene(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)  # nowhere near the repository's folders
    mission = resolve_mission(Path("hajj_emergency"))
    assert mission == mission_path("hajj_emergency") and mission.is_file()
    assert mission.read_bytes() == (REPO / "missions" / "hajj_emergency.yaml").read_bytes()
    scene = default_scene(mission)
    assert scene is not None and scene.resolve() == (REPO / "scenes" / "hajj_emergency.yaml").resolve()
    assert resolve_scene(Path("hajj_normal")) == scene_path("hajj_normal")
    (emergency,) = [m for m in shipped_missions() if m.name == "hajj_emergency"]
    assert emergency.scene == "hajj_emergency"
    assert emergency.summary == yaml.safe_load(mission.read_text(encoding="utf-8"))["goal"]


def test_paths_keep_working_and_a_local_file_wins_over_a_shipped_name(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(REPO)
    assert resolve_mission(Path("missions/hajj_emergency.yaml")) == Path("missions/hajj_emergency.yaml")
    assert resolve_mission(Path("elsewhere/gone.yaml")) == Path("elsewhere/gone.yaml")  # the loader says it
    monkeypatch.chdir(tmp_path)
    (tmp_path / "hajj_emergency").write_text("plan_id: mine\n")
    assert resolve_mission(Path("hajj_emergency")) == Path("hajj_emergency")
    with pytest.raises(ExampleError, match=r"^elsewhere\.yaml: no such scene file$"):
        resolve_scene(Path("elsewhere.yaml"))


@pytest.mark.parametrize(("argv", "kind"), [(["nope"], "mission"), (["hajj_emergency", "--scene", "nope"], "scene")])
def test_an_unknown_name_is_one_line_listing_the_shipped_ones(
    argv: list[str], kind: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["run", *argv, "--runs-dir", str(tmp_path / "runs")]) == 2
    err = capsys.readouterr().err
    names = ", ".join(_stems(REPO / f"{kind}s"))
    assert err == (
        f"agentic-uav run: error: nope: no such {kind} file, and no shipped {kind} of that name "
        f"(shipped: {names}; see agentic-uav examples)\n"
    )
    assert not (tmp_path / "runs").exists()


def test_examples_lists_every_shipped_mission_with_its_goal_and_every_scene(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["examples"]) == 0
    out = capsys.readouterr().out
    for path in sorted((REPO / "missions").rglob("*.yaml")):
        goal = yaml.safe_load(path.read_text(encoding="utf-8"))["goal"]
        assert any(line.split()[:1] == [path.stem] and goal in line for line in out.splitlines()), path.stem
    for path in sorted((REPO / "scenes").glob("*.yaml")):
        assert any(line.split()[:1] == [path.stem] for line in out.splitlines()), path.stem
    assert main(["examples", "list"]) == 0 and capsys.readouterr().out == out


def test_copy_writes_them_out_laid_out_so_a_copied_mission_finds_its_scene(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    dest = tmp_path / "new" / "folder"
    assert main(["examples", "copy", str(dest)]) == 0
    expected = sorted(
        p.relative_to(REPO).as_posix()
        for kind in ("missions", "scenes")
        for p in (REPO / kind).rglob("*")
        if p.is_file()
    )
    assert sorted(p.relative_to(dest).as_posix() for p in dest.rglob("*") if p.is_file()) == expected
    for name in expected:
        assert (dest / name).read_bytes() == (REPO / name).read_bytes()
    assert default_scene(dest / "missions" / "hajj_emergency.yaml") == dest / "scenes" / "hajj_emergency.yaml"
    assert f"wrote {len(expected)} files to {dest}" in capsys.readouterr().out


def test_copy_refuses_to_overwrite_anything_without_force(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    edited = tmp_path / "missions" / "hajj_patrol.yaml"
    edited.parent.mkdir()
    edited.write_text("my edits\n")
    assert main(["examples", "copy", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err == f"agentic-uav examples: error: {edited}: already there; nothing was copied (--force overwrites)\n"
    assert edited.read_text() == "my edits\n"
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["hajj_patrol.yaml", "missions"]  # nothing else written
    assert main(["examples", "copy", str(tmp_path), "--force"]) == 0
    assert edited.read_bytes() == (REPO / "missions" / "hajj_patrol.yaml").read_bytes()


def test_copy_over_a_file_or_under_a_file_is_a_clear_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    assert main(["examples", "copy", str(a_file)]) == 2
    assert capsys.readouterr().err == f"agentic-uav examples: error: {a_file}: exists and is not a folder\n"
    (tmp_path / "d").mkdir()
    (tmp_path / "d" / "scenes").write_text("x")
    assert main(["examples", "copy", str(tmp_path / "d"), "--force"]) == 2
    assert "d/scenes: exists and is not a folder" in capsys.readouterr().err
    assert not (tmp_path / "d" / "missions").exists()
    with pytest.raises(ExampleError, match=r"a_file/under/missions(/examples)?: cannot write: Not a directory"):
        copy_examples(a_file / "under")


def test_plan_and_validate_take_a_shipped_name_too(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    plan_id = yaml.safe_load((REPO / "missions" / "hajj_patrol.yaml").read_text(encoding="utf-8"))["plan_id"]
    assert main(["plan", "hajj_patrol"]) == 0
    assert capsys.readouterr().out.startswith(f"{plan_id}: ")
    assert main(["validate", "hajj_patrol", "nope"]) == 2
    out, err = capsys.readouterr()
    assert out.startswith(f"hajj_patrol: ok: plan {plan_id!r}")
    assert err.startswith("nope: no such mission file, and no shipped mission of that name")
    assert main(["plan", "nope"]) == 2
    assert capsys.readouterr().err.startswith("agentic-uav plan: error: nope: no such mission file")


def test_a_package_not_on_disk_is_a_clear_error_not_a_crash(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import zipfile

    import agentic_core.examples as examples

    archive = tmp_path / "zipped.zip"
    with zipfile.ZipFile(archive, "w") as z:
        z.writestr("agentic_core/examples/missions/x.yaml", "plan_id: x\n")
    monkeypatch.setattr(examples, "files", lambda _name: zipfile.Path(archive, "agentic_core/examples/"))
    with pytest.raises(ExampleError, match=r"the shipped examples are not on disk .*; install agentic-uavs unzipped"):
        mission_path("x")
