"""``python -m agentic_core`` runs the ``agentic-uav`` command line."""

import sys

from .cli import main

sys.exit(main())
