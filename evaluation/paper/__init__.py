"""Reproducing the paper's statistics from its published summary figures.

>>> from evaluation.paper import reproduce
>>> table = reproduce()
>>> print(table.to_text())          # figure, paper's value, recomputed value, verdict and reason

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
