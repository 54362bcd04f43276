"""What a study module returns: tables and figures with their titles and notes."""

from __future__ import annotations

from dataclasses import dataclass, field

import pandas as pd


@dataclass
class TableSpec:
    """One reproduced table: file stem, title, the frame (units in every header) and a note.

    ``bound``: the note states our results only through placeholders (``{{ table | row | column | fmt }}``,
    :mod:`pipeline.studies.prose`), filled when the table is written; the prose check then holds every
    other number of the note to the document, the settings and the study's ``prose_facts``, as it does
    a study file's reasons, instead of to any cell of the study."""

    name: str
    title: str
    frame: pd.DataFrame
    note: str = ""
    bound: bool = False


@dataclass
class FigureSpec:
    """One figure: file names written (PNG first), title and caption (``bound``: as :class:`TableSpec`'s;
    a caption holds no placeholder, so every number in it is the document's, a setting or a fact)."""

    files: list[str]
    title: str
    caption: str = ""
    extra: dict = field(default_factory=dict)
    bound: bool = False
