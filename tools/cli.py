"""``agentic-uav tools list|describe``: the tool catalogue as a table, JSON, or OpenAI / MCP tool lists."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence

from .errors import ToolDefinitionError, UnknownToolError
from .loading import build_registry
from .registry import ToolDescription, ToolRegistry


def add_source_options(parser: argparse.ArgumentParser) -> None:
    """``--tools`` and ``--no-builtins``, shared by every command that builds the registry."""
    parser.add_argument(
        "--tools",
        action="append",
        default=[],
        metavar="SOURCE",
        help="more tools: a module (mypkg.tools), a .py file, or a YAML/JSON file of HTTP endpoints (repeatable)",
    )
    parser.add_argument("--no-builtins", action="store_true", help="leave out the built-in tools")


def registry_from_args(args: argparse.Namespace) -> ToolRegistry:
    return build_registry(args.tools, builtins=not args.no_builtins)


def _limits(tool: ToolDescription) -> str:
    parts = [tool.rate_limit or "", f"caller {tool.caller_rate_limit}" if tool.caller_rate_limit else ""]
    parts += [f"timeout {tool.timeout_s:g}s" if tool.timeout_s else "no timeout"]
    parts += [f"retry {tool.retry_attempts}" if tool.retry_attempts > 1 else ""]
    parts += [f"cache {tool.cache_ttl_s:g}s" if tool.cache_ttl_s else ""]
    return ", ".join(p for p in parts if p)


def _table(catalogue: list[ToolDescription]) -> str:
    rows = [("TOOL", "SCOPES", "LIMITS", "BREAKER", "DESCRIPTION")]
    for tool in catalogue:
        state = tool.breaker if tool.available else f"{tool.breaker}, unavailable"
        text = tool.description if len(tool.description) <= 60 else tool.description[:57] + "..."
        rows.append((tool.name, " ".join(tool.scopes) or "-", _limits(tool), state, text))
    widths = [max(len(row[i]) for row in rows) for i in range(4)]
    lines = ["  ".join(cell.ljust(w) for cell, w in zip(row[:4], widths, strict=True)) + "  " + row[4] for row in rows]
    return "\n".join(line.rstrip() for line in lines)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="agentic-uav tools", description="The tool catalogue.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    listing = sub.add_parser("list", help="list the registered tools")
    listing.add_argument(
        "--format",
        choices=["table", "json", "openai", "mcp"],
        default="table",
        help="table (default); json (every field); openai (chat-completions tools=[...]); mcp (tools/list result)",
    )
    add_source_options(listing)
    describe = sub.add_parser("describe", help="one tool's schemas, scopes, limits and state, as JSON")
    describe.add_argument("name")
    add_source_options(describe)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        registry = registry_from_args(args)
        if args.command == "describe":
            print(registry.describe(registry.resolve(args.name)).model_dump_json(indent=2))
            return 0
    except (ToolDefinitionError, UnknownToolError) as exc:
        print(f"agentic-uav tools: error: {exc}", file=sys.stderr)
        return 2
    if args.format == "table":
        print(_table(registry.catalogue()))
    elif args.format == "json":
        print(json.dumps([t.model_dump() for t in registry.catalogue()], indent=2))
    elif args.format == "openai":
        print(json.dumps(registry.to_openai(), indent=2))
    else:
        print(json.dumps({"tools": registry.to_mcp()}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
