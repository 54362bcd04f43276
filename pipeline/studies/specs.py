"""What a study module returns: tables and figures with their titles and notes."""

from __future__ import annotations

from dataclasses import dataclass, field

import pandas as pd


@dataclass
class TableSpec:
    """One reproduced table: file stem, title, the frame (units in every header) and a note."""

    name: str
    title: str
    frame: pd.DataFrame
    note: str = ""


@dataclass
class FigureSpec:
    """One figure: file names written (PNG first), title and caption."""

    files: list[str]
    title: str
    caption: str = ""
    extra: dict = field(default_factory=dict)
