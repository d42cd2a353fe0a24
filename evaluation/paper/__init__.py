"""Reproducing the paper's statistics from its published summary figures.

>>> from evaluation.paper import reproduce
>>> table = reproduce()
>>> table.to_text().splitlines()[0]  # then each figure, the paper's value, ours, the verdict and the reason
'Reproducing: Agentic UAVs: LLM-Driven Autonomy with Integrated Tool-Calling and Cognitive Reasoning'
>>> table.rows[0].figure_id, table.rows[0].verdict
('n_total', 'reproduced')

The figures live in ``figures.json`` (package data), each with the section, table and line of
``paper/agentic_uavs.tex`` it was read from.
"""

from __future__ import annotations

from evaluation.paper.cli import main
from evaluation.paper.figures import Figure, PaperFigures, load_figures
from evaluation.paper.reproduce import VERDICTS, Reproduction, ReproductionRow, SupplementaryRow, reproduce

__all__ = [
    "VERDICTS",
    "Figure",
    "PaperFigures",
    "Reproduction",
    "ReproductionRow",
    "SupplementaryRow",
    "load_figures",
    "main",
    "reproduce",
]
