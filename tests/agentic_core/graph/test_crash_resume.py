"""A run whose process is killed mid-mission resumes from its SQLite checkpoint in a new process."""

import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

from tests.waiting import wait_for

MISSION = textwrap.dedent(
    """
    import operator, os, signal, sys, time
    from pathlib import Path
    from typing import Annotated, TypedDict
    from agentic_core.graph import END, START, SqliteSaver, StateGraph

    db, effects, mode = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3]
    crash_at = int(os.environ.get("CRASH_AT", "-1"))
    pause = float(os.environ.get("PAUSE_S", "0"))

    def effect(text):
        with effects.open("a") as f:
            f.write(text + "\\n")

    class S(TypedDict, total=False):
        leg: int
        log: Annotated[list[str], operator.add]

    def fly_leg(s):
        leg = s["leg"]
        if leg == crash_at:
            os.kill(os.getpid(), signal.SIGKILL)  # the process dies in the middle of this node
        time.sleep(pause)
        effect(f"leg {leg}")
        return {"leg": leg + 1, "log": [f"leg {leg}"]}

    def photograph(s):
        effect("photo")
        return {"log": ["photo"]}

    def release_kit(s):
        import sqlite3
        probe = sqlite3.connect(db)
        latest = "SELECT checkpoint_id FROM agentic_checkpoints ORDER BY seq DESC LIMIT 1"
        saved = f"SELECT COUNT(*) FROM agentic_writes WHERE checkpoint_id = ({latest})"
        while not probe.execute(saved).fetchone()[0]:
            time.sleep(0.01)  # wait until photograph (same superstep) has finished and its outcome is saved
        if os.environ.get("CRASH_IN_PARALLEL"):
            os.kill(os.getpid(), signal.SIGKILL)
        effect("kit")
        return {"log": ["kit"]}

    g = StateGraph(S)
    g.add_node("fly_leg", fly_leg)
    g.add_node("photograph", photograph)
    g.add_node("release_kit", release_kit)
    g.add_edge(START, "fly_leg")
    g.add_conditional_edges("fly_leg", lambda s: "fly_leg" if s["leg"] < 6 else "payload", {"fly_leg": "fly_leg",
                            "payload": "photograph"})
    g.add_conditional_edges("fly_leg", lambda s: [] if s["leg"] < 6 else ["release_kit"], ["release_kit"])
    g.add_edge("photograph", END)
    g.add_edge("release_kit", END)
    saver = SqliteSaver(db)
    app = g.compile(checkpointer=saver)
    config = {"configurable": {"thread_id": "mission-1"}}
    out = app.invoke({"leg": 0, "log": []} if mode == "start" else None, config)
    print("RESULT", __import__("json").dumps(out))
    """
)


def run(tmp_path: Path, mode: str, **env: str) -> subprocess.CompletedProcess[str]:
    script = tmp_path / "mission.py"
    script.write_text(MISSION)
    return subprocess.run(
        [sys.executable, str(script), str(tmp_path / "ckpt.sqlite"), str(tmp_path / "effects.txt"), mode],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, **env},
    )


def result(proc: subprocess.CompletedProcess[str]) -> dict[str, object]:
    line = [x for x in proc.stdout.splitlines() if x.startswith("RESULT ")]
    assert line, proc.stderr
    out: dict[str, object] = json.loads(line[0][len("RESULT ") :])
    return out


def effects(tmp_path: Path) -> list[str]:
    return (tmp_path / "effects.txt").read_text().splitlines()


EXPECTED_LOG = [f"leg {i}" for i in range(6)] + ["photo", "kit"]


def test_killed_mid_node_resumes_without_losing_or_repeating_steps(tmp_path: Path) -> None:
    (tmp_path / "effects.txt").touch()
    crashed = run(tmp_path, "start", CRASH_AT="3")
    assert crashed.returncode == -signal.SIGKILL
    assert effects(tmp_path) == ["leg 0", "leg 1", "leg 2"]
    resumed = run(tmp_path, "resume")
    assert resumed.returncode == 0, resumed.stderr
    assert result(resumed) == {"leg": 6, "log": EXPECTED_LOG}
    assert effects(tmp_path) == EXPECTED_LOG  # every side effect exactly once


def test_killed_in_a_parallel_step_keeps_the_finished_task(tmp_path: Path) -> None:
    (tmp_path / "effects.txt").touch()
    crashed = run(tmp_path, "start", CRASH_IN_PARALLEL="1")
    assert crashed.returncode == -signal.SIGKILL
    assert effects(tmp_path)[-1] == "photo"
    resumed = run(tmp_path, "resume")
    assert resumed.returncode == 0, resumed.stderr
    assert result(resumed) == {"leg": 6, "log": EXPECTED_LOG}
    assert effects(tmp_path).count("photo") == 1  # photograph finished before the crash and did not run again


def test_killed_from_outside_at_an_arbitrary_moment(tmp_path: Path) -> None:
    (tmp_path / "effects.txt").touch()
    script = tmp_path / "mission.py"
    script.write_text(MISSION)
    proc = subprocess.Popen(
        [sys.executable, str(script), str(tmp_path / "ckpt.sqlite"), str(tmp_path / "effects.txt"), "start"],
        env={**os.environ, "PAUSE_S": "0.2"},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    wait_for(lambda: len(effects(tmp_path)) >= 2, 60, interval_s=0.02, what="two effects of the mission")
    proc.send_signal(signal.SIGKILL)
    proc.wait(30)
    done_before = effects(tmp_path)
    assert 2 <= len(done_before) < 6
    resumed = run(tmp_path, "resume")
    assert resumed.returncode == 0, resumed.stderr
    assert result(resumed) == {"leg": 6, "log": EXPECTED_LOG}
    # a node whose effect was written but whose checkpoint was not may run again (at-least-once); no more
    after = effects(tmp_path)
    assert sorted(set(after)) == sorted(set(EXPECTED_LOG))
    assert len(after) - len(EXPECTED_LOG) <= 1
