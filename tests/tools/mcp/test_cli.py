"""The ``mcp serve`` command: its parser, the registry it builds, its refusals; and the docstring examples."""

import doctest
import importlib
import subprocess
import sys

import httpx
import pytest

from tools.cli import registry_from_args
from tools.mcp.cli import build_parser, local_caller, main

from .conftest import OUR_SERVER, ROOT, SECRET


def test_the_parser_and_the_registry() -> None:
    argv = ["serve", "--no-builtins", "--tools", "tests.tools.mcp.sample_tools", "--scopes", "a:b", "c:*"]
    args = build_parser().parse_args(argv)
    assert (args.http, args.host, args.port) == (False, "127.0.0.1", 8765)
    assert registry_from_args(args).names() == [
        "sample.add",
        "sample.echo",
        "sample.fail",
        "sample.slow",
        "sample.wind",
    ]
    with_builtins = registry_from_args(build_parser().parse_args(["serve", "--tools", "tests.tools.mcp.sample_tools"]))
    assert {"weather.get_forecast", "alerts.notify", "sample.echo"} <= set(with_builtins.names())
    assert local_caller(args.scopes).scopes == frozenset({"a:b", "c:*"})
    assert local_caller(args.scopes).id.startswith("local:")


def test_refusals(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.delenv("AGENTIC_UAV_TOKEN_SECRET", raising=False)
    assert main(["serve", "--http", "--host", "0.0.0.0", "--port", "0"]) == 2
    assert "AGENTIC_UAV_TOKEN_SECRET" in capsys.readouterr().err
    assert main(["serve", "--tools", "tests.tools.mcp.no_such_module"]) == 2
    assert "no_such_module" in capsys.readouterr().err
    monkeypatch.setenv("AGENTIC_UAV_TOKEN_SECRET", "short")
    assert main(["serve", "--http", "--port", "0"]) == 2
    assert "at least 32 bytes" in capsys.readouterr().err


def test_the_http_command_requires_tokens_from_the_secret() -> None:
    env = {"AGENTIC_UAV_TOKEN_SECRET": SECRET, "PATH": "/usr/bin:/bin"}
    with subprocess.Popen(
        [*OUR_SERVER, "--http", "--port", "0"], cwd=ROOT, env=env, stderr=subprocess.PIPE, text=True
    ) as process:
        try:
            assert process.stderr is not None
            line = process.stderr.readline()
            assert "bearer tokens required" in line, line
            url = line.split(" on ", 1)[1].split(" ", 1)[0]
            assert httpx.post(url, json={"jsonrpc": "2.0", "id": 1, "method": "ping"}).status_code == 401
        finally:
            process.terminate()
            assert process.wait(timeout=10) == 0


MODULES = [
    "tools.mcp",
    "tools.mcp.protocol",
    "tools.mcp.server",
    "tools.mcp.http_transport",
    "tools.mcp.client",
    "tools.mcp.anonymous",
    "tools.mcp.refused",
]


@pytest.mark.parametrize("name", [*MODULES, "tools.mcp.cli"])
def test_docstring_examples(name: str) -> None:
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0, f"{name} has no runnable example"
    assert result.failed == 0


def test_python_dash_m_prints_help() -> None:
    done = subprocess.run([sys.executable, "-m", "tools.mcp", "--help"], cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 0 and "serve" in done.stdout
