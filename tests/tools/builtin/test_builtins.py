"""register_builtins and BuiltinConfig: names, guards, settings from the environment, the secret kept secret,
the layer rule, and the runnable examples in the modules' docstrings."""

from __future__ import annotations

import ast
import doctest
import importlib
from pathlib import Path

import pytest

import tools
from tools import ToolRegistry
from tools.builtin import BuiltinConfig, register_builtins

NAMES = [
    "weather.get_forecast",
    "alerts.send_email",
    "alerts.webhook",
    "alerts.notify",
    "incidents.log",
    "incidents.query",
]
MODULES = [
    "tools.builtin",
    "tools.builtin.config",
    "tools.builtin.weather",
    "tools.builtin.outbox",
    "tools.builtin.mail",
    "tools.builtin.eml",
    "tools.builtin.webhook",
    "tools.builtin.alerts",
    "tools.builtin.incidents",
    "tools.http_endpoint",
    "tools.yaml_source",
]


def test_registers_every_builtin_with_its_guards(config: BuiltinConfig) -> None:
    registry = ToolRegistry()
    assert register_builtins(registry, config) == NAMES
    described = {name: registry.describe(name) for name in NAMES}
    assert {n: d.scopes for n, d in described.items()} == {
        "weather.get_forecast": ["weather:read"],
        "alerts.send_email": ["alerts:send"],
        "alerts.webhook": ["alerts:send"],
        "alerts.notify": ["alerts:send"],
        "incidents.log": ["incidents:write"],
        "incidents.query": ["incidents:read"],
    }
    weather = described["weather.get_forecast"]
    assert (weather.idempotent, weather.cache_ttl_s, weather.retry_attempts, weather.rate_limit) == (
        True,
        300,
        3,
        "10/s",
    )
    for name in ("alerts.send_email", "alerts.webhook", "alerts.notify", "incidents.log"):
        assert not described[name].idempotent and described[name].cache_ttl_s is None
    assert {spec.name for spec in registry if spec.untrusted_output} == {"alerts.webhook", "incidents.query"}
    notify = registry.get("alerts.notify").input_schema
    assert list(notify["properties"]) == ["subject", "body", "channel", "to", "attach"]
    assert notify["required"] == ["subject", "body"]
    assert notify["properties"]["channel"]["enum"] == ["email", "webhook", "log"]
    assert all(spec.output_schema is not None for spec in registry)


def test_settings_come_from_the_environment(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    env = {
        "AGENTIC_UAV_OUTBOX_DIR": str(tmp_path / "out"),
        "AGENTIC_UAV_INCIDENTS_DB": str(tmp_path / "i.db"),
        "AGENTIC_UAV_WEATHER_BASE_URL": "https://api.open-meteo.com",
        "AGENTIC_UAV_SMTP_HOST": "smtp.example.org",
        "AGENTIC_UAV_SMTP_PORT": "2525",
        "AGENTIC_UAV_SMTP_STARTTLS": "false",
        "AGENTIC_UAV_SMTP_USERNAME": "ops",
        "AGENTIC_UAV_SMTP_PASSWORD": "s3cret-value",
        "AGENTIC_UAV_SMTP_FROM": "UAV <uav@example.org>",
        "AGENTIC_UAV_ALERT_RECIPIENTS": "a@example.org; b@example.org, c@example.org",
        "AGENTIC_UAV_WEBHOOK_URL": "https://hooks.example.org/x",
        "AGENTIC_UAV_HTTP_TIMEOUT_S": "2.5",
        "AGENTIC_UAV_SMTP_CA_FILE": "",  # empty means unset
    }
    for name, value in env.items():
        monkeypatch.setenv(name, value)
    config = BuiltinConfig.from_env()
    assert config.outbox_dir == tmp_path / "out" and config.incidents_db == tmp_path / "i.db"
    assert (config.smtp_host, config.smtp_port, config.smtp_starttls) == ("smtp.example.org", 2525, False)
    assert config.smtp_password is not None and config.smtp_password.get_secret_value() == "s3cret-value"
    assert config.alert_recipients == ["a@example.org", "b@example.org", "c@example.org"]
    assert (config.http_timeout_s, config.smtp_ca_file) == (2.5, None)
    for text in (repr(config), str(config), config.model_dump_json()):
        assert "s3cret-value" not in text
    registry = ToolRegistry()
    register_builtins(registry)  # no config: from the environment
    assert registry.describe("weather.get_forecast").timeout_s == 2.5 * 2 + 5


def test_a_bad_setting_names_its_variable() -> None:
    with pytest.raises(ValueError, match="AGENTIC_UAV_SMTP_PORT"):
        BuiltinConfig.from_env({"AGENTIC_UAV_SMTP_PORT": "smtp"})
    with pytest.raises(ValueError, match="AGENTIC_UAV_HTTP_TIMEOUT_S"):
        BuiltinConfig.from_env({"AGENTIC_UAV_HTTP_TIMEOUT_S": "-1"})
    defaults = BuiltinConfig.from_env({})
    assert (defaults.outbox_dir, defaults.incidents_db, defaults.smtp_port) == (
        Path("runs/outbox"),
        Path("runs/incidents.db"),
        587,
    )


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name: str) -> None:
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0, f"{name} has no runnable example"
    assert result.failed == 0


def test_tools_layer_imports_no_higher_layer() -> None:
    root = Path(tools.__file__).parent
    files = [*root.joinpath("builtin").glob("*.py"), root / "http_endpoint.py", root / "http_call.py"]
    files.append(root / "yaml_source.py")
    offenders = []
    for path in files:
        for node in ast.walk(ast.parse(path.read_text())):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else []
            if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            offenders += [
                f"{path.name}: {n}"
                for n in names
                if n.split(".")[0] in {"agentic_core", "flight", "evaluation"}
                and not n.startswith("agentic_core.contracts")  # the bottom layer, below tools
            ]
    assert not offenders
