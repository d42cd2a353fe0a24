"""The operator at the terminal (``--approval ask``): yes and no, silence and a closed input both decline."""

from __future__ import annotations

import io
import os
import threading

import pytest

from agentic_core.run.cli import build_parser, main
from agentic_core.run.operator import TerminalOperator

REQUEST = {"step": "land_near", "args": {"target_id": "P-3", "offset_m": 5.0}, "question": "approve land (land_near)?"}


@pytest.mark.parametrize(("line", "approved"), [("y\n", True), ("Yes please\n", True), ("n\n", False), ("\n", False)])
def test_a_line_starting_with_y_approves_anything_else_declines(line: str, approved: bool) -> None:
    out = io.StringIO()
    answer = TerminalOperator(io.StringIO(line), out, timeout_s=5.0)(REQUEST)
    assert answer.approved is approved and answer.said == line.strip()
    assert "approve land (land_near)? (target_id=P-3, offset_m=5.0) [y/N]" in out.getvalue()


def test_no_answer_in_time_declines_and_a_late_answer_goes_to_the_next_question() -> None:
    read_fd, write_fd = os.pipe()
    before = sum(t.name == "operator-input" for t in threading.enumerate())
    with os.fdopen(read_fd) as answers, os.fdopen(write_fd, "w") as typing:
        operator = TerminalOperator(answers, io.StringIO(), timeout_s=0.2)
        silent = operator(REQUEST)
        assert not silent.approved and silent.said is None and "no answer in 0.2 s" in silent.why
        typing.write("y\n")
        typing.flush()
        assert operator(REQUEST).approved  # one reader: the answer is not lost to the first, timed-out prompt
        readers = sum(t.name == "operator-input" for t in threading.enumerate())
        assert readers - before == 1  # one reader for both prompts, whatever else the process runs


def test_an_input_that_has_ended_declines_every_question() -> None:
    operator = TerminalOperator(io.StringIO(""), io.StringIO(), timeout_s=5.0)
    assert [operator(REQUEST).why for _ in range(2)] == ["the operator's input ended: declined"] * 2


def test_the_cli_takes_approval_ask_and_refuses_a_contradiction(capsys: pytest.CaptureFixture[str]) -> None:
    args = build_parser().parse_args(["m.yaml", "--approval", "ask", "--approval-timeout-s", "30"])
    assert (args.approval, args.approval_timeout_s) == ("ask", 30.0)
    assert main(["missions/hajj_emergency.yaml", "--approval", "ask", "--decline", "--quiet"]) == 2
    assert "--decline contradicts --approval ask" in capsys.readouterr().err
