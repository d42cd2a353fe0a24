"""The operator at the terminal: a mission step marked ``approval`` pauses the mission graph (``interrupt``) and
the run asks here; the answer resumes the graph from its checkpoint.

A line starting with ``y`` approves, anything else declines; no answer within ``timeout_s`` declines (the safe
answer: the aircraft does not land near people unasked). Lines are read on one background thread, so a prompt
that timed out does not leave a reader behind to swallow the next answer.

>>> import io
>>> ask = TerminalOperator(io.StringIO("y\\n"), io.StringIO(), timeout_s=1.0)
>>> answer = ask({"step": "land_near", "question": "approve land (land_near)?"})
>>> answer.approved, answer.said, answer.why, answer.timed_out
(True, 'y', 'the operator approved', False)
"""

from __future__ import annotations

import queue
import threading
from typing import Any, TextIO

from ..agent.control import OperatorAnswer


class TerminalOperator:
    """Asks approval questions on ``out`` and reads the answers from ``answers`` (a terminal, a pipe)."""

    def __init__(self, answers: TextIO, out: TextIO, *, timeout_s: float = 120.0) -> None:
        self.answers = answers
        self.out = out
        self.timeout_s = timeout_s
        self._lines: queue.Queue[str | None] = queue.Queue()
        self._reader: threading.Thread | None = None

    def _read(self) -> None:
        while True:
            line = self.answers.readline()
            self._lines.put(line if line else None)
            if not line:
                return

    def __call__(self, request: dict[str, Any]) -> OperatorAnswer:
        if self._reader is None:
            self._reader = threading.Thread(target=self._read, name="operator-input", daemon=True)
            self._reader.start()
        question = request.get("question") or f"approve {request.get('step')}?"
        print(f"\n>>> operator: {question} {_detail(request)}[y/N] ", end="", file=self.out, flush=True)
        try:
            line = self._lines.get(timeout=self.timeout_s)
        except queue.Empty:
            print("(no answer)", file=self.out, flush=True)
            return OperatorAnswer(False, None, f"no answer in {self.timeout_s:g} s: declined", timed_out=True)
        if line is None:
            self._lines.put(None)  # the input has ended: every later question gets the same
            return OperatorAnswer(False, None, "the operator's input ended: declined")
        said = line.strip()
        approved = said.lower().startswith("y")
        return OperatorAnswer(approved, said, "the operator approved" if approved else "the operator declined")


def _detail(request: dict[str, Any]) -> str:
    args = request.get("args")
    return f"({', '.join(f'{k}={v}' for k, v in args.items())}) " if isinstance(args, dict) and args else ""


__all__ = ["OperatorAnswer", "TerminalOperator"]
