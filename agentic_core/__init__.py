"""agentic-uavs: drones as agents.

The cognitive core: a typed state-graph runtime (:mod:`agentic_core.graph`) and, as later issues land, the mission
DSL, the reasoners, perception and cross-mission memory.
"""

__version__ = "0.1.0.dev0"
