"""``python -m evaluation.paper``: the same as ``agentic-uav eval paper``."""

from evaluation.paper.cli import main

raise SystemExit(main())
