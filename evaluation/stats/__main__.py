"""``python -m evaluation.stats``: the same as ``agentic-uav eval stats``."""

from evaluation.stats.cli import main

raise SystemExit(main())
