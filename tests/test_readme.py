"""The README's quickstart runs and prints what the README says it prints."""

import contextlib
import io
import re
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"


def test_quickstart_runs_as_documented() -> None:
    code = re.findall(r"```python\n(.*?)```", README.read_text(), re.S)[0]
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, "README.md", "exec"), {"__name__": "readme"})
    lines = out.getvalue().splitlines()
    assert lines[0].startswith("[Interrupt(value={'question': 'land near the crowd?'}, id=")
    assert lines[1] == "['leg 0', 'leg 1', 'leg 2', 'landed']"
    assert "graph TD;" in lines
