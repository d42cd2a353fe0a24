"""Swarm runs as the console lists and replays them (``agentic-uav swarm run``'s ``runs/<swarm-id>/``): one entry
per swarm with its UAVs, outcome and closest separation, and one replay with every UAV's flight and events and the
swarm's own (rounds, awards, claims, verifications, deliveries, refusals) on one clock, read from the files alone.

Every file is read bounded (:func:`~agentic_core.console.reading.read_jsonl`); a UAV folder is only ever a plain
folder directly inside the swarm's, whatever ``summary.json`` says.

>>> import tempfile
>>> list_swarms(Path(tempfile.mkdtemp()))
[]
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any, TypeGuard

from ..contracts.errors import InputError
from ..contracts.geodesy import offset_position
from .reading import read_json, read_jsonl
from .runs import RUN_ID, TELEMETRY_POINTS, _map, _thin
from .swarm_events import refusal_event, swarm_event

SWARM_LOG = "swarm.jsonl"
SUMMARY = "summary.json"
REFUSALS = "refusals.jsonl"
LOG_BYTES = 16_000_000
"""``swarm.jsonl``, ``refusals.jsonl`` and each UAV's ``trace.jsonl`` are read up to this many bytes."""
TELEMETRY_BYTES = 64_000_000
"""Each UAV's ``telemetry.jsonl`` is read up to this many bytes (an hour at 10 Hz is about 20 MB)."""
SUMMARY_BYTES = 1_000_000
SAMPLE_KEYS = ("time_s", "lat_deg", "lon_deg", "alt_m", "vn_mps", "ve_mps", "yaw_deg", "battery_pct", "mode")
SAMPLE_FLAGS = ("armed", "landed_state", "gps_fix_type")
"""What the page shows of a UAV's sample (the rest stays in its file)."""
UAV_DIR = re.compile(r"^\d{8}-\d{6}-(uav-\d{1,4})-")


def is_swarm(folder: Path) -> bool:
    """Whether ``folder`` is a swarm run's (it holds ``swarm.jsonl`` or ``summary.json``)."""
    return not folder.is_symlink() and ((folder / SWARM_LOG).is_file() or (folder / SUMMARY).is_file())


def list_swarms(runs_dir: Path) -> list[dict[str, Any]]:
    """Every swarm run under ``runs_dir``, newest first: kind ``swarm``, its UAVs, outcome (``running`` until its
    summary), closest separation; one whose files cannot be read is listed with its ``error``."""
    if not runs_dir.is_dir():
        return []
    found = []
    for folder in sorted((p for p in runs_dir.iterdir() if p.is_dir() and is_swarm(p)), reverse=True):
        if not RUN_ID.match(folder.name):
            continue
        summary, problem = read_json(folder / SUMMARY, SUMMARY_BYTES)
        uavs = uav_folders(folder, summary)
        said, separation = _dict(summary.get("uavs")), _dict(summary.get("separation"))
        entry: dict[str, Any] = {
            "id": folder.name, "kind": "swarm", "outcome": str(summary.get("outcome") or "running"),
            "vehicles": len(uavs) or summary.get("vehicles"), "min_separation_m": separation.get("min_distance_m"),
            "sim_s": summary.get("sim_s"), "mission": summary.get("mission"),
            "uavs": [{"uav": uav, "run_id": path.name, "outcome": _said(said, uav, "outcome"),
                      "role": _said(said, uav, "role")} for uav, path in uavs.items()],
        }  # fmt: skip
        if problem and (folder / SUMMARY).exists():
            entry["error"] = problem
        found.append(entry)
    return found


def listing(runs_dir: Path, runs: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The console's list: its runs (kind ``run``) and its swarms, newest first."""
    every = [{**r, "kind": "run"} for r in runs] + list_swarms(runs_dir)
    return sorted(every, key=lambda r: str(r["id"]), reverse=True)


def swarm_folder(runs_dir: Path, swarm_id: str) -> Path:
    """The folder of ``swarm_id``; :class:`InputError` for an id that is not a swarm run's (no paths)."""
    if not RUN_ID.match(swarm_id) or not is_swarm(runs_dir / swarm_id):
        raise InputError(f"no swarm run {swarm_id!r} in {runs_dir}")
    return runs_dir / swarm_id


def uav_folders(folder: Path, summary: dict[str, Any]) -> dict[str, Path]:
    """Each UAV's run folder, by UAV: the folders ``summary.json`` names (by their last part only) and those named
    like a UAV's run, each a real folder directly in ``folder`` with a ``trace.jsonl``; sorted by UAV number."""
    found: dict[str, Path] = {}
    said = _dict(summary.get("uavs"))
    for uav, about in said.items():
        name = Path(str(about.get("run_dir") or "")).name if isinstance(about, dict) else ""
        if isinstance(uav, str) and re.fullmatch(r"uav-\d{1,4}", uav) and _own(folder, name):
            found[uav] = folder / name
    for path in sorted(folder.iterdir()):
        match = UAV_DIR.match(path.name)
        if match and match.group(1) not in found and _own(folder, path.name):
            found[match.group(1)] = path
    return dict(sorted(found.items(), key=lambda item: int(item[0].split("-")[1])))


def _own(folder: Path, name: str) -> bool:
    path = folder / name
    return bool(RUN_ID.match(name)) and path.is_dir() and not path.is_symlink() and (path / "trace.jsonl").is_file()


def _said(said: dict[str, Any], uav: str, key: str) -> Any:
    about = said.get(uav)
    return about.get(key) if isinstance(about, dict) else None


def replay_swarm(runs_dir: Path, swarm_id: str) -> dict[str, Any]:
    """One swarm run for the time slider: the map (the scene, the mission's geofence, the sectors and who was
    awarded each, the casualties), each UAV's thinned flight, and one timeline of every UAV's events and the
    swarm's, each tagged with its UAV; ``problems`` names every file that could not be read whole."""
    folder = swarm_folder(runs_dir, swarm_id)
    summary, problem = read_json(folder / SUMMARY, SUMMARY_BYTES)
    problems = [problem] if problem and (folder / SUMMARY).exists() else []
    log, cut = read_jsonl(folder / SWARM_LOG, LOG_BYTES)
    refusals, cut_refusals = read_jsonl(folder / REFUSALS, LOG_BYTES)
    problems += [p for p in (cut, cut_refusals) if p]
    uavs = uav_folders(folder, summary)
    shown = _map(next(iter(uavs.values()))) if uavs else {}
    if "mission" in shown:  # each UAV flies its own share: the shared geofence and ceiling, not one UAV's legs
        shown["mission"] = {**shown["mission"], "legs": []}
    home = shown.get("scene", {}).get("home")
    vehicles, events = [], []
    per_uav = max(200, TELEMETRY_POINTS // max(1, len(uavs)))
    for uav, path in uavs.items():
        trace, cut_trace = read_jsonl(path / "trace.jsonl", LOG_BYTES)
        telemetry, cut_telemetry = read_jsonl(path / "telemetry.jsonl", TELEMETRY_BYTES, keep=per_uav)
        problems += [f"{uav}: {p}" for p in (cut_trace, cut_telemetry) if p]
        runs = [r for r in trace if r.get("kind") == "run"]
        ended = bool(runs) and runs[-1].get("event") == "end"
        vehicles.append({"uav": uav, "run_id": path.name, "telemetry": [_cut(s) for s in _thin(telemetry, per_uav)],
                         "outcome": runs[-1].get("outcome") if ended else "running",
                         "role": _said(_dict(summary.get("uavs")), uav, "role")})  # fmt: skip
        events += [{**e, "uav": uav} for e in trace]
    clock = [(float(r["t"]), float(r["sim_t"])) for r in log if _number(r.get("t")) and _number(r.get("sim_t"))]
    events += [swarm_event(r) for r in log]
    events += [refusal_event(r, clock) for r in refusals]
    events.sort(key=lambda e: float(e["sim_t"]) if _number(e.get("sim_t")) else 0.0)
    return {
        "swarm_id": swarm_id, "kind": "swarm", "live": False, **shown,
        "outcome": str(summary.get("outcome") or "running"), "summary": summary or None,
        "vehicles": vehicles, "events": events, "sectors": _sectors(log, summary),
        "casualties": _casualties(log, summary, home), "problems": problems,
    }  # fmt: skip


def _cut(sample: dict[str, Any]) -> dict[str, Any]:
    return {key: sample.get(key) for key in (*SAMPLE_KEYS, *SAMPLE_FLAGS)}


def _dict(value: Any) -> dict[str, Any]:
    return value if isinstance(value, dict) else {}


def _number(value: Any) -> TypeGuard[int | float]:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _sectors(log: list[dict[str, Any]], summary: dict[str, Any]) -> list[dict[str, Any]]:
    """The sectors as drawn: corners, the UAV awarded each (the last award wins: a dead UAV's sector moves) and
    who surveyed it."""
    corners: dict[str, list[list[float]]] = {}
    awarded: dict[str, str] = {}
    for record in log:
        if record.get("event") == "sectors" and isinstance(record.get("sectors"), dict):
            for sector, points in record["sectors"].items():
                points = points if isinstance(points, list) else []
                ok = [_dict(p) for p in points if _number(_dict(p).get("lat")) and _number(_dict(p).get("lon"))]
                corners[str(sector)] = [[p["lat"], p["lon"]] for p in ok]
        task, winner = str(record.get("task") or ""), record.get("awarded")
        if record.get("event") == "round" and task.startswith("survey:") and isinstance(winner, str):
            awarded[task.split(":", 1)[1]] = winner
        if record.get("event") in ("sectors", "consensus") and isinstance(winner, dict):
            for key, uav in winner.items():
                awarded[str(key).removeprefix("survey:")] = str(uav)
    covered: dict[str, Any] = dict(_dict(summary.get("sectors")))
    for record in log:
        if record.get("event") == "covered" and not summary:
            covered.setdefault(str(record.get("sector")), []).append(record.get("uav"))
    return [{"id": s, "polygon": points, "awarded": awarded.get(s), "surveyed_by": covered.get(s) or []}
            for s, points in corners.items()]  # fmt: skip


def _casualties(log: list[dict[str, Any]], summary: dict[str, Any], home: Any) -> list[dict[str, Any]]:
    """Each casualty claimed: where (from the claim, metres from the scene's home), who found, verified and was
    awarded its kit, and whether it was delivered."""
    found: dict[str, dict[str, Any]] = {}
    for record in log:
        event, casualty = record.get("event"), str(record.get("casualty") or "")
        if event == "claim" and record.get("claimed") and casualty:
            where = _dict(record.get("where"))
            north, east = where.get("north"), where.get("east")
            at = None
            if isinstance(home, list) and len(home) == 2 and _number(north) and _number(east):
                at = list(offset_position(float(home[0]), float(home[1]), float(north), float(east)))
            found[casualty] = {"id": casualty, "at": at, "found_by": record.get("uav"), "object": record.get("object"),
                               "verified_by": [], "verified": False, "delivery_awarded": None,
                               "delivered": False}  # fmt: skip
        elif event == "verify" and casualty in found:
            found[casualty].update(verified_by=record.get("seen_by") or [], verified=bool(record.get("verified")))
        elif event == "delivered" and casualty in found:
            found[casualty]["delivered"] = True
        if isinstance(record.get("awarded"), dict):
            for task, uav in record["awarded"].items():
                kind, _, rest = str(task).partition(":")
                if kind == "deliver_kit" and rest.rsplit(":", 1)[-1] in found:
                    found[rest.rsplit(":", 1)[-1]]["delivery_awarded"] = uav
        elif str(record.get("task") or "").startswith("deliver_kit:") and record.get("event") == "round":
            name = str(record["task"]).rsplit(":", 1)[-1]
            if name in found:
                found[name]["delivery_awarded"] = record.get("awarded")
    return list(found.values())


__all__ = ["is_swarm", "list_swarms", "listing", "replay_swarm", "swarm_folder", "uav_folders"]
