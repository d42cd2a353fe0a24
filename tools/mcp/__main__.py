"""``python -m tools.mcp serve ...``: the MCP server command (see :mod:`tools.mcp.cli`)."""

import sys

from .cli import main

sys.exit(main())
