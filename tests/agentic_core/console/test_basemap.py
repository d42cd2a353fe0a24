"""The ground picture under the map: the route answers a run's scene as a PNG laid over the bounds the map is
told (the home inside them), with the token only, refuses ids that are paths or no run, says so for a run without
a scene, draws a live run from its own scene, renders a scene once; in the browser the picture lies on the map
under the vectors, and a toggle hides it."""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Any

import httpx
import matplotlib.image
import pytest

from agentic_core.agent import ControlPort
from agentic_core.console import ConsoleServer, LiveFeed
from agentic_core.console.app import Live
from agentic_core.console.basemap import GroundPictures, ground_bounds
from agentic_core.console.runs import replay
from flight.sim.scene_file import load_scene

REPO = Path(__file__).resolve().parents[3]
RUN = "20260101-000000-ground"


def write_run(runs: Path, run_id: str = RUN, *, scene: bool = True) -> Path:
    folder = runs / run_id
    folder.mkdir(parents=True)
    settings: dict[str, Any] = {"mission": str(REPO / "missions" / "hajj_emergency.yaml")}
    settings["scene"] = str(REPO / "scenes" / "hajj_emergency.yaml") if scene else None
    if not scene:
        settings["mission"] = str(runs / "gone.yaml")  # no scene named, none found by the mission's name
    (folder / "run.json").write_text(json.dumps({"run_id": run_id, "settings": settings}), encoding="utf-8")
    start = {"kind": "run", "seq": 1, "sim_t": 0.0, "event": "start", "mission": "m.yaml", "summary": "start"}
    (folder / "trace.jsonl").write_text(json.dumps(start), encoding="utf-8")
    return folder


def test_the_route_answers_the_runs_ground_as_a_png_over_the_bounds_the_map_is_told(tmp_path: Path) -> None:
    write_run(tmp_path)
    scene = load_scene(REPO / "scenes" / "hajj_emergency.yaml")
    with ConsoleServer(tmp_path, port=0) as server:
        base = f"http://127.0.0.1:{server.port}"
        auth = {"Authorization": f"Bearer {server.token}"}
        answer = httpx.get(f"{base}/api/runs/{RUN}/ground.png", headers=auth, timeout=30)
        assert answer.status_code == 200 and answer.headers["content-type"] == "image/png"
        assert httpx.get(f"{base}/api/runs/{RUN}/ground.png", timeout=30).status_code == 403  # no token
        for bad in ("..%2F..%2Fetc", "%2E%2E", "no-such-run", ".hidden"):
            refused = httpx.get(f"{base}/api/runs/{bad}/ground.png", headers=auth, timeout=30)
            assert refused.status_code == 404 and refused.headers["content-type"] != "image/png", bad
    picture = matplotlib.image.imread(io.BytesIO(answer.content), format="png")
    (south, west), (north, east) = replay(tmp_path, RUN)["scene"]["ground"]["bounds"]
    assert [[south, west], [north, east]] == ground_bounds(scene)
    assert south < scene.home.lat_deg < north and west < scene.home.lon_deg < east
    aspect = (north - south) / (east - west) / 0.9306  # a degree of longitude at 21.4° is 0.93 of one of latitude
    assert picture.shape[0] / picture.shape[1] == pytest.approx(aspect, rel=0.01)


def test_a_run_without_a_scene_is_told_not_drawn(tmp_path: Path) -> None:
    write_run(tmp_path, scene=False)
    with ConsoleServer(tmp_path, port=0) as server:
        answer = httpx.get(f"http://127.0.0.1:{server.port}/api/runs/{RUN}/ground.png",
                           headers={"Authorization": f"Bearer {server.token}"}, timeout=30)  # fmt: skip
    assert answer.status_code == 404 and "no scene" in answer.json()["error"]


def test_a_live_run_is_drawn_from_its_own_scene_and_no_other_id_is(tmp_path: Path) -> None:
    feed = LiveFeed()
    feed.static = {"run_id": "live-1", "live": True, "mission": None}
    scene = load_scene(REPO / "scenes" / "inspect_perimeter.yaml")  # no run folder: only the live run knows it
    with ConsoleServer(tmp_path, port=0, live=Live(feed, ControlPort(), scene)) as server:
        base, auth = f"http://127.0.0.1:{server.port}", {"Authorization": f"Bearer {server.token}"}
        answer = httpx.get(f"{base}/api/runs/live-1/ground.png", headers=auth, timeout=30)
        other = httpx.get(f"{base}/api/runs/live-2/ground.png", headers=auth, timeout=30)
    assert answer.status_code == 200 and answer.content == GroundPictures().png(scene)
    assert other.status_code == 404


def test_a_scene_is_rendered_once_and_the_pictures_kept_are_bounded() -> None:
    scene = load_scene(REPO / "scenes" / "hajj_emergency.yaml")
    pictures = GroundPictures(kept=1)
    first = pictures.png(scene)
    assert pictures.png(scene) is first  # the same bytes, not a second rendering
    other = scene.model_copy(update={"seed": scene.seed + 1})
    assert pictures.png(other) != first and len(pictures._pictures) == 1


def test_the_picture_lies_on_the_map_under_the_vectors_and_the_toggle_hides_it(browser: Any, tmp_path: Path) -> None:
    write_run(tmp_path)
    with ConsoleServer(tmp_path, port=0) as server:
        page = browser.new_page()
        requested: list[str] = []
        page.on("request", lambda request: requested.append(request.url))
        page.goto(server.url)
        overlay = page.locator(".leaflet-ground-pane img.ground-picture")
        overlay.wait_for(state="attached", timeout=30_000)
        assert (overlay.get_attribute("src") or "").startswith("data:image/png;base64,")
        page.wait_for_function("() => document.querySelector('img.ground-picture').naturalWidth > 0", timeout=20_000)
        zs = page.evaluate("() => ['ground', 'overlay'].map(p => +getComputedStyle(document.querySelector("
                           "`.leaflet-${p}-pane`)).zIndex)")  # fmt: skip
        assert zs[0] < zs[1]  # under the zones and landmarks
        page.get_by_label("ground picture").uncheck()
        page.wait_for_function("() => !document.querySelector('img.ground-picture')", timeout=10_000)
        page.close()
    own = f"http://127.0.0.1:{server.port}/"
    assert any(url.endswith("/ground.png") for url in requested) and all(url.startswith(own) for url in requested)
