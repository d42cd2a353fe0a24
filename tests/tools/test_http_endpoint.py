"""Tools from HTTP endpoint descriptions: argument placement, auth from the environment, answers, retries, and
load errors that name the file, line, column and field. Calls go to a real server on 127.0.0.1."""

from __future__ import annotations

import asyncio
import json
import textwrap
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
from pydantic import ValidationError

from tests.tools.builtin.local_http import LocalHTTPServer, Reply, free_port, json_reply, text_reply
from tools import Caller, ToolDefinitionError, ToolExecutor, ToolRegistry
from tools.http_endpoint import HttpEndpoint, http_tool, load_http_tools, register_http_tools

ROOT = Caller(id="tester", scopes=frozenset({"*"}))
EXAMPLE = Path(__file__).parents[2] / "tools" / "examples" / "http_tools.yaml"
TOKEN = "tok-3f9a-very-secret"


@pytest.fixture(autouse=True)
def loopback_allowed(monkeypatch: pytest.MonkeyPatch) -> None:
    """These tests talk to a server on 127.0.0.1, which the egress policy refuses unless allowed."""
    monkeypatch.setenv("AGENTIC_UAV_EGRESS_ALLOW", "127.0.0.1")


class Tools:
    def __init__(self) -> None:
        self.registry = ToolRegistry()
        self.delays: list[float] = []
        self.executor = ToolExecutor(self.registry, default_caller=ROOT, sleep=self.delays.append)

    def load(self, path: Path) -> list[str]:
        return register_http_tools(self.registry, path)

    def call(self, name: str, args: dict[str, Any]) -> Any:
        return self.executor.call(name, args)


@pytest.fixture
def tools() -> Iterator[Tools]:
    made = Tools()
    yield made
    made.executor.close()


def write(folder: Path, text: str, name: str = "endpoints.yaml") -> Path:
    path = folder / name
    path.write_text(textwrap.dedent(text).lstrip("\n"))
    return path


def problems(path: Path) -> list[str]:
    with pytest.raises(ToolDefinitionError) as caught:
        load_http_tools(path)
    return str(caught.value).replace(str(path), path.name).splitlines()


def roads(base: str, **extra: str) -> str:
    lines = "".join(f"    {key}: {value}\n" for key, value in extra.items())
    return f"""
tools:
  - name: traffic.road_status
    description: Road closures near a point.
    method: GET
    url: {base}/v2/roads/{{region}}/status
    params:
      type: object
      properties: {{region: {{type: string}}, radius_km: {{type: number, default: 5}}, open_only: {{type: boolean}}}}
      required: [region]
    headers: {{Accept: application/json}}
    auth: {{header: Authorization, env: TRAFFIC_TOKEN, scheme: Bearer}}
{lines}"""


# --- calls -------------------------------------------------------------------------------------------------------
def test_get_places_path_query_defaults_and_bearer_token(
    tools: Tools, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("TRAFFIC_TOKEN", TOKEN)
    with LocalHTTPServer([json_reply({"closures": [{"road": "King Fahd", "closed": True}]})]) as server:
        assert tools.load(write(tmp_path, roads(server.url))) == ["traffic.road_status"]
        result = tools.call("traffic.road_status", {"region": "Mina East/2", "open_only": True})
    assert result.ok, result.error
    assert result.output == {"closures": [{"road": "King Fahd", "closed": True}]}
    assert result.untrusted
    (request,) = server.requests
    assert request.method == "GET" and request.path == "/v2/roads/Mina%20East%2F2/status"
    assert request.query == {"radius_km": ["5"], "open_only": ["true"]}
    assert request.headers["authorization"] == f"Bearer {TOKEN}" and request.headers["accept"] == "application/json"
    assert request.body == b""
    description = tools.registry.describe("traffic.road_status")
    assert description.source == "http" and description.input_schema["additionalProperties"] is False


def test_post_sends_the_rest_as_a_json_body(tools: Tools, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("DISPATCH_KEY", TOKEN)
    with LocalHTTPServer([json_reply({"ticket": 17}, status=201)]) as server:
        tools.load(
            write(
                tmp_path,
                f"""
                tools:
                  - name: dispatch.create_ticket
                    method: post
                    url: {server.url}/teams/{{team}}/tickets
                    params:
                      type: object
                      properties:
                        team: {{type: string}}
                        summary: {{type: string}}
                        where: {{type: object}}
                        notify: {{type: boolean, default: true}}
                      required: [team, summary]
                    query: [notify]
                    auth: {{header: X-Api-Key, env: DISPATCH_KEY}}
                """,
            )
        )
        result = tools.call(
            "dispatch.create_ticket", {"team": "medical", "summary": "collapse", "where": {"lat": 21.4}}
        )
    assert result.ok and result.output == {"ticket": 17}
    (request,) = server.requests
    assert request.method == "POST" and request.path == "/teams/medical/tickets"
    assert request.query == {"notify": ["true"]}
    assert request.json() == {"summary": "collapse", "where": {"lat": 21.4}}
    assert request.headers["x-api-key"] == TOKEN and request.headers["content-type"] == "application/json"


def test_auth_as_query_parameter(tools: Tools, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("AQ_KEY", TOKEN)
    endpoint = HttpEndpoint(name="aq.now", url="http://unused.example/aq", auth={"query": "appid", "env": "AQ_KEY"})
    seen: list[httpx.Request] = []

    def answer(request: httpx.Request) -> httpx.Response:
        seen.append(request)
        return httpx.Response(400, text=f"bad key {TOKEN}")  # an echo of the secret must not reach the agent

    tools.registry.register(http_tool(endpoint, transport=httpx.MockTransport(answer)))
    result = tools.call("aq.now", {})
    assert seen[0].url.params["appid"] == TOKEN
    assert result.status == "error" and "HTTP 400" in (result.error or "") and TOKEN not in (result.error or "")
    assert "***" in (result.error or "")


def test_missing_auth_variable_is_a_result_naming_it(
    tools: Tools, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv("TRAFFIC_TOKEN", raising=False)
    with LocalHTTPServer([json_reply({})]) as server:
        tools.load(write(tmp_path, roads(server.url)))  # loading does not need the secret
        result = tools.call("traffic.road_status", {"region": "mina"})
    assert result.status == "error" and result.attempts == 1
    assert "TRAFFIC_TOKEN" in (result.error or "")
    assert server.requests == []


def test_text_answers_are_wrapped_and_long_ones_truncated(tools: Tools, tmp_path: Path) -> None:
    big = "é" * 75_000  # 150 kB of UTF-8: the cut falls inside a character
    replies = [text_reply("<b>road open</b>", content_type="text/html"), text_reply(big), Reply(204)]
    with LocalHTTPServer(replies) as server:
        path = write(tmp_path, f"tools:\n  - name: page.get\n    url: {server.url}/page\n")
        tools.load(path)
        short, long, empty = (tools.call("page.get", {}) for _ in range(3))
    assert short.output == {
        "status": 200, "content_type": "text/html", "text": "<b>road open</b>", "truncated": False, "bytes": 16,
    }  # fmt: skip
    assert long.output["truncated"] is True and long.output["bytes"] == 150_000
    assert long.output["text"] == "é" * 50_000  # 100 kB, no broken character at the end
    assert empty.output["status"] == 204 and empty.output["text"] == ""


def test_503_is_retried_then_ok_and_404_is_not(tools: Tools, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("TRAFFIC_TOKEN", TOKEN)

    def answer(request: Any) -> Reply:
        if "unknown" in request.path:
            return text_reply("no such region: unknown", status=404)
        return Reply(503, b"busy") if len(server.requests) == 1 else json_reply({"closures": []})

    with LocalHTTPServer(answer) as server:
        tools.load(write(tmp_path, roads(server.url, idempotent="true", retry="3", cache_ttl_s="60")))
        result = tools.call("traffic.road_status", {"region": "mina"})
        missing = tools.call("traffic.road_status", {"region": "unknown"})
    assert result.ok and result.attempts == 2 and result.output == {"closures": []}
    assert tools.delays and len(tools.delays) == 1
    assert missing.status == "error" and missing.attempts == 1
    assert "HTTP 404" in (missing.error or "") and "no such region: unknown" in (missing.error or "")
    assert len(server.requests) == 3


def test_non_idempotent_posts_retry_only_when_nothing_was_processed(tools: Tools, tmp_path: Path) -> None:
    replies = [Reply(503), json_reply({"ok": True}), text_reply("crashed", status=500)]
    with LocalHTTPServer(replies) as server:
        tools.load(
            write(tmp_path, f"tools:\n  - name: ops.post\n    method: POST\n    url: {server.url}/\n    retry: 3\n")
        )
        first = tools.call("ops.post", {})
        second = tools.call("ops.post", {})
    assert first.ok and first.attempts == 2
    assert second.status == "error" and second.attempts == 1 and "HTTP 500" in (second.error or "")
    down_url = f"http://127.0.0.1:{free_port()}/"
    path = write(
        tmp_path, f"tools:\n  - name: ops.post\n    method: POST\n    url: {down_url}\n    retry: 3\n", "d.yaml"
    )
    other = Tools()
    other.load(path)
    down = other.call("ops.post", {})
    other.executor.close()
    assert down.status == "error" and down.attempts == 3 and "cannot reach" in (down.error or "")


def test_slow_answers_are_retried_only_when_idempotent(tools: Tools, tmp_path: Path) -> None:
    def slow(_request: Any) -> Reply:
        time.sleep(0.6)
        return json_reply({})

    with LocalHTTPServer(slow) as server:
        text = f"""
        tools:
          - {{name: slow.read, url: "{server.url}/r", timeout_s: 0.2, retry: 3, idempotent: true}}
          - {{name: slow.write, method: POST, url: "{server.url}/w", timeout_s: 0.2, retry: 3}}
        """
        tools.load(write(tmp_path, text))
        read = tools.call("slow.read", {})
        written = tools.call("slow.write", {})
    assert read.status in ("error", "timeout") and read.attempts == 3
    assert written.status in ("error", "timeout") and written.attempts == 1  # it may have been acted on
    assert [r.path for r in server.requests].count("/w") == 1


def test_output_schema_is_enforced(tools: Tools, tmp_path: Path) -> None:
    with LocalHTTPServer([json_reply({"closures": "none"})]) as server:
        text = f"""
        tools:
          - name: traffic.summary
            url: {server.url}/s
            output: {{type: object, properties: {{closures: {{type: array}}}}, required: [closures]}}
        """
        tools.load(write(tmp_path, text))
        result = tools.call("traffic.summary", {})
    assert result.status == "error" and "does not match its schema" in (result.error or "")


def test_async_callers_and_injected_transports(tools: Tools) -> None:
    endpoint = HttpEndpoint(
        name="feed.items",
        url="https://feed.example/items",
        params={"type": "object", "properties": {"tag": {"type": "array", "items": {"type": "string"}}}},
    )
    transport = httpx.MockTransport(
        lambda request: httpx.Response(
            200, headers={"content-type": "application/problem+json"}, json={"tags": request.url.params.get_list("tag")}
        )
    )
    tools.registry.register(http_tool(endpoint, transport=transport))
    result = asyncio.run(tools.executor.acall("feed.items", {"tag": ["fire", "crowd"]}))
    assert result.ok and result.output == {"tags": ["fire", "crowd"]}


# --- loading -----------------------------------------------------------------------------------------------------
def test_load_errors_name_file_line_column_and_field(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        """
        tools:
          - name: traffic.road_status
            method: FETCH
            url: https://api.example.org/v2/roads/{region}/status
            query: [radius]
            timeout_s: ten
            cache_ttl_s: 60
            rate_limit: 5 per second
            metod: GET
          - description: no name, no url
          - name: traffic.bad_schema
            url: https://api.example.org/x
            params:
              type: object
              properties:
                lat: {type: numbr}
            auth: {header: Authorization, query: key, env: TOKEN}
        """,
    )
    assert problems(path) == [
        "endpoints.yaml:3:5: tools[0].method: 'FETCH' is not one of GET, POST, PUT, PATCH, DELETE",
        "endpoints.yaml:4:5: tools[0].url: placeholder {region} is not a declared param (add it to params.properties)",
        "endpoints.yaml:5:13: tools[0].query[0]: 'radius' is not a declared param",
        "endpoints.yaml:6:5: tools[0].timeout_s: Input should be a valid number, unable to parse string as a number"
        " (got 'ten')",
        "endpoints.yaml:7:5: tools[0].cache_ttl_s: only idempotent endpoints may cache results: add 'idempotent: true'",
        "endpoints.yaml:8:5: tools[0].rate_limit: rate limit '5 per second': write it as COUNT/UNIT, e.g. '10/s',"
        " '30/min', '500/h'",
        "endpoints.yaml:9:5: tools[0].metod: unknown field; did you mean 'method'?",
        "endpoints.yaml:10:5: tools[1].name: required field missing",
        "endpoints.yaml:10:5: tools[1].url: required field missing",
        "endpoints.yaml:16:15: tools[2].params.properties.lat.type: not valid JSON Schema: 'numbr' is not valid under"
        " any of the given schemas",
        "endpoints.yaml:17:5: tools[2].auth: give 'header' or 'query', not both",
    ]


def test_load_errors_in_json_files_and_yaml_syntax(tmp_path: Path) -> None:
    body = {"tools": [{"name": "a.b", "url": "ftp://files.example/x", "retry": 0}]}
    path = write(tmp_path, json.dumps(body, indent=2), "endpoints.json")
    assert problems(path) == [
        "endpoints.json:5:7: tools[0].url: 'ftp://files.example/x' is not an http:// or https:// URL",
        "endpoints.json:6:7: tools[0].retry: Input should be greater than or equal to 1 (got '0')",
    ]
    path = write(tmp_path, "tools:\n  - name: a.b\n    url: [unclosed\n", "broken.yaml")
    (problem,) = problems(path)
    assert problem.startswith("broken.yaml:4:1: not valid YAML or JSON")


def test_load_errors_of_the_file_as_a_whole(tmp_path: Path) -> None:
    assert problems(write(tmp_path, "", "empty.yaml")) == [
        "empty.yaml:1:1: tools: expected a non-empty 'tools:' list of endpoint descriptions"
    ]
    text = """
    tools:
      - name: a.one
        url: https://x.example/1
        url: https://x.example/2
      - name: a.one
        url: https://x.example/3
    extras: true
    """
    assert problems(write(tmp_path, text, "twice.yaml")) == [
        "twice.yaml:4:5: tools[0].url: 'url' is written twice (first at line 3)",
        "twice.yaml:5:5: tools[1].name: 'a.one' is already defined (line 2)",
        "twice.yaml:7:1: extras: unknown top-level field (only 'tools')",
    ]
    with pytest.raises(ToolDefinitionError, match=r"nowhere\.yaml: cannot read it"):
        load_http_tools(tmp_path / "nowhere.yaml")


def test_path_parameters_must_be_declared_and_required(tmp_path: Path) -> None:
    params = {"type": "object", "properties": {"region": {"type": "string"}}}
    with pytest.raises(ValidationError, match=r"url: path parameter \{region\} must be required or have a default"):
        HttpEndpoint(name="a.b", url="https://x.example/{region}", params=params)
    with pytest.raises(ValidationError, match=r"url: placeholder \{zone\} is not a declared param"):
        HttpEndpoint(name="a.b", url="https://x.example/{zone}", params=params)
    ok = HttpEndpoint(name="a.b", url="https://x.example/{region}", params={**params, "required": ["region"]})
    assert ok.placeholders == ["region"]


def test_the_example_file_loads_and_registers(tools: Tools) -> None:
    names = tools.load(EXAMPLE)
    assert names == ["traffic.road_status", "airquality.current", "dispatch.create_ticket"]
    assert tools.registry.describe("traffic.road_status").cache_ttl_s == 60
    assert not tools.registry.describe("dispatch.create_ticket").idempotent
    assert tools.registry.describe("dispatch.create_ticket").side_effects
    assert not tools.registry.describe("traffic.road_status").side_effects
    with pytest.raises(ToolDefinitionError, match=r"already registered: traffic\.road_status"):
        tools.load(EXAMPLE)
    assert register_http_tools(tools.registry, EXAMPLE, replace=True) == names


def test_a_secret_is_scrubbed_as_written_and_as_urls_and_json_quote_it() -> None:
    from tools.http_call import _scrub

    secret = "ab+cd/ef=="
    page = f"invalid key for https://wx.example/now?appid=ab%2Bcd%2Fef%3D%3D (also ab%2Bcd%2Fef%3D%3D, {secret})"
    assert _scrub(page, secret) == "invalid key for https://wx.example/now?appid=*** (also ***, ***)"
    assert _scrub('{"key": "ab+cd\\/ef=="}', "ab+cd/ef==") == '{"key": "***"}'
