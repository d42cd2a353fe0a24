"""The Assessment contract (defined in :mod:`agentic_core.contracts.assessment`, re-exported here) and the text of
its JSON Schema shipped in ``prompts/schemas/assessment.schema.json``.

>>> import json
>>> json.loads(schema_text())["title"], Decision is DecisionRecord
('Assessment', True)
"""

from __future__ import annotations

import json

from agentic_core.contracts.assessment import (
    CONTEXTUAL_MIN_CHARS,
    SEVERITIES,
    Assessment,
    Decision,
    DecisionRecord,
    Severity,
    assessment_json_schema,
)


def schema_text() -> str:
    """:func:`assessment_json_schema` as the text shipped in ``prompts/schemas/assessment.schema.json``."""
    return json.dumps(assessment_json_schema(), indent=2) + "\n"


__all__ = [
    "CONTEXTUAL_MIN_CHARS",
    "SEVERITIES",
    "Assessment",
    "Decision",
    "DecisionRecord",
    "Severity",
    "assessment_json_schema",
    "schema_text",
]
