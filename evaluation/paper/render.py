"""Text and Markdown renderings of a :class:`~evaluation.paper.reproduce.Reproduction`."""

from __future__ import annotations

import textwrap

from evaluation.paper.reproduce import Reproduction
from evaluation.stats.render_markdown import markdown_table

_WIDTHS = {"figure": 44, "where": 16, "paper": 22, "recomputed": 40, "verdict": 16}


def _cell(text: str, width: int) -> list[str]:
    return textwrap.wrap(text, width) or [""]


def render_text(rep: Reproduction) -> str:
    """A fixed-width table for a terminal; each row's reason is printed under it."""
    keys = list(_WIDTHS)
    header = "  ".join(k.capitalize().ljust(_WIDTHS[k]) for k in keys).rstrip()
    lines = [f"Reproducing: {rep.paper}", "", header, "-" * len(header)]
    for row in rep.rows:
        cells = [_cell(getattr(row, k), _WIDTHS[k]) for k in keys]
        height = max(len(c) for c in cells)
        for i in range(height):
            parts = [(c[i] if i < len(c) else "").ljust(_WIDTHS[k]) for c, k in zip(cells, keys, strict=True)]
            lines.append("  ".join(parts).rstrip())
        for reason_line in textwrap.wrap(row.reason, len(header) - 4):
            lines.append(f"    {reason_line}")
        lines.append("")
    counts = rep.counts()
    lines.append("Summary: " + ", ".join(f"{v}: {c}" for v, c in counts.items()))
    if rep.supplementary:
        lines.extend(["", "Recomputed from the summary figures but not reported in the paper:"])
        for s in rep.supplementary:
            lines.append(f"  - {s.statistic}: {s.value}")
            lines.extend(f"      {w}" for w in textwrap.wrap(s.note, 100))
    if rep.notes:
        lines.append("")
        lines.extend(textwrap.fill(n, 110) for n in rep.notes)
    return "\n".join(lines) + "\n"


def render_markdown(rep: Reproduction) -> str:
    rows = [[r.figure, r.where, r.paper, r.recomputed, f"**{r.verdict}**", r.reason] for r in rep.rows]
    parts = [
        f"# Reproducing the paper: {rep.paper}",
        "",
        markdown_table(["Figure", "Where", "Paper", "Recomputed", "Verdict", "Reason"], rows),
        "",
        "Summary: " + ", ".join(f"{v}: {c}" for v, c in rep.counts().items()),
        "",
    ]
    if rep.supplementary:
        parts.extend(
            [
                "## Recomputed but not reported in the paper",
                "",
                markdown_table(
                    ["Statistic", "Value", "Note"], [[s.statistic, s.value, s.note] for s in rep.supplementary]
                ),
                "",
            ]
        )
    parts.extend(f"- {n}" for n in rep.notes)
    return "\n".join(parts) + "\n"


__all__ = ["render_markdown", "render_text"]
