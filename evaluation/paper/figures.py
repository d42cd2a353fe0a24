"""The paper's published figures (``figures.json``), each with the line of ``agentic_uavs.tex`` it comes from."""

from __future__ import annotations

import json
import re
from functools import lru_cache
from importlib import resources
from typing import Literal

from pydantic import BaseModel, ConfigDict

DATA_FILE = "figures.json"


class Where(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")

    section: str
    table: str | None = None
    line: int

    def short(self) -> str:
        if self.table:
            return f"{self.table.split(' (')[0]}, l.{self.line}"
        section = self.section.split(" ›")[0].split(" ")[0]
        return f"§{section} l.{self.line}" if section != "Abstract" else f"Abstract l.{self.line}"


class Figure(BaseModel):
    """One number (or claim) as printed in the paper."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    id: str
    quantity: str
    role: Literal["input", "claim", "descriptive", "method"]
    value: float | list[float] | None
    relation: Literal["=", "≈", "<", ">", "≪", "claim"]
    display: str | None = None
    """How the table shows a claim that is not a number."""
    unit: str | None = None
    resolution: float | None = None
    """One unit of the last printed digit, in the unit of ``value`` (e.g. 0.01 for "79%" as 0.79)."""
    group: str | None = None
    printed: str
    """The exact TeX text on ``where.line``."""
    where: Where

    @property
    def scalar(self) -> float:
        if not isinstance(self.value, int | float):
            raise TypeError(f"figure {self.id} is not a single number")
        return float(self.value)

    @property
    def text(self) -> str:
        return tex_to_text(self.printed)


class PaperInfo(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")

    title: str
    authors: str
    file: str
    note: str


class Group(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")

    name: str
    short: str


class PaperFigures(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")

    paper: PaperInfo
    groups: dict[str, Group]
    figures: list[Figure]

    def get(self, figure_id: str) -> Figure:
        for f in self.figures:
            if f.id == figure_id:
                return f
        raise KeyError(figure_id)

    def value(self, figure_id: str) -> float:
        return self.get(figure_id).scalar


@lru_cache(maxsize=1)
def load_figures() -> PaperFigures:
    """The packaged data file (needs ``figures.json`` listed as package data of ``evaluation.paper``)."""
    text = resources.files("evaluation.paper").joinpath(DATA_FILE).read_text(encoding="utf-8")
    return PaperFigures.model_validate(json.loads(text))


_TEX = [
    (r"\textbf{", ""),
    (r"\chi^2", "χ²"),
    (r"\approx", "≈"),
    (r"\times", "×"),
    (r"\alpha", "α"),
    (r"\pm", "±"),
    (r"\mu", "µ"),
    (r"\ll", "≪"),
    (r"\sim", "~"),
    (r"\%", "%"),
    (r"\,", " "),
    ("\\ ", " "),
    ("$", ""),
    ("}", ""),
]


def tex_to_text(tex: str) -> str:
    """``$29.5 \\pm 9.4\\,\\mu$s`` → ``29.5 ± 9.4 µs`` (enough TeX for the figures in the data file)."""
    text = tex
    for old, new in _TEX:
        text = text.replace(old, new)
    text = re.sub(r"\s+", " ", text)
    text = re.sub(r"(\d) µ ?s", r"\1 µs", text)
    return text.strip()


__all__ = ["DATA_FILE", "Figure", "Group", "PaperFigures", "Where", "load_figures", "tex_to_text"]
