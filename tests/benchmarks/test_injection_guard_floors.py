"""``benchmarks/injection_guard.py`` on the corpus: it runs, prints its table, and stays at or above the figures
measured when the held-out split was first scanned (dev: 177 of 179 hostile flagged, no benign; held-out: 5 of 44
hostile, 1 of 45 benign). The floors are those counts, not targets: a change that lowers one fails here."""

import json
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "injection_guard.py"
MEASURED = {  # split: (hostile entries, benign entries, true positives at least, false positives at most)
    "dev": (179, 195, 177, 0),
    "heldout": (44, 45, 5, 1),
}


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True, timeout=600)


def test_the_guard_keeps_its_measured_figures_on_both_splits() -> None:
    done = _run("--json")
    assert done.returncode == 0, done.stderr
    counts = json.loads(done.stdout)
    for split, (hostile, benign, true_positives, false_positives) in MEASURED.items():
        row = counts[split]["all"]["all"]
        assert (row["hostile"], row["benign"]) == (hostile, benign), f"{split}: the corpus changed size: {row}"
        assert row["true_positives"] >= true_positives, f"{split}: recall fell: {row}"
        assert row["false_positives"] <= false_positives, f"{split}: precision fell: {row}"
    languages = set(counts["heldout"]["lang"])
    assert {"en", "fr", "ar", "ur", "zh"} <= languages


def test_the_table_names_splits_languages_and_categories() -> None:
    done = _run()
    assert done.returncode == 0, done.stderr
    for expected in ("dev:", "heldout:", "lang=ur", "category=authority", "category=json_tool_call", "recall"):
        assert expected in done.stdout, expected
