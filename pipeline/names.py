"""The one pattern for names and folder paths that reach file paths, Snakemake config or a shell command.

Names (robot, study, problem-set and solver ids) are what the workflow joins into file paths and
Snakemake wildcards; folder paths (``--results``, ``--data``, the ``results_dir``/``data_dir`` config
keys) are pasted into the ``shell:`` commands of the rules. Neither may carry text a shell or
``str.format`` would act on, so both are checked against fixed patterns before they are used, and a
value that does not match is refused in one line naming the argument:

``NAME_PATTERN``
    lowercase ASCII letters and digits in runs joined by single underscores, at most
    ``NAME_MAX`` (64) characters: ``ur5e``, ``kuka_lwr``, ``arm_benchmark``. (A double underscore
    separates robot and solver in archive names, so a name never holds one.)
``PATH_PATTERN``
    ASCII letters, digits and ``. _ - + /`` (no space, quote, ``$``, backtick, ``;``, ``|``, ``,``, ``=``,
    ``&``, ``<``, ``>``, brace, bracket, ``*``, ``?``, ``~`` or non-ASCII letter); not starting with ``-``;
    at most ``PATH_MAX`` (1024) characters.
"""

from __future__ import annotations

import re

from pipeline.errors import UsageError

NAME_MAX = 64
PATH_MAX = 1024
NAME_PATTERN = r"[a-z0-9]+(?:_[a-z0-9]+)*"
PATH_PATTERN = r"[A-Za-z0-9._+/][A-Za-z0-9._+/-]*"
_NAME = re.compile(NAME_PATTERN)
_PATH = re.compile(PATH_PATTERN)
NAME_RULE = f"lowercase letters and digits joined by single underscores, at most {NAME_MAX} characters"
PATH_RULE = ("letters, digits and . _ - + / only (no spaces, quotes or shell characters), not starting with -, "
             f"at most {PATH_MAX} characters")


def _shown(value: str) -> str:
    text = repr(value)
    return text if len(text) <= 80 else text[:70] + "...'" + f" ({len(value)} characters)"


def is_name(value) -> bool:
    """True when ``value`` is a string matching :data:`NAME_PATTERN` within :data:`NAME_MAX` characters."""
    return isinstance(value, str) and len(value) <= NAME_MAX and _NAME.fullmatch(value) is not None


def check_name(value, what: str) -> str:
    """``value`` if it is a valid name (:data:`NAME_PATTERN`), else a :class:`UsageError` naming ``what``."""
    if not is_name(value):
        raise UsageError(f"{what} {_shown(str(value))}: not a valid name (use {NAME_RULE})")
    return value


def check_path(value, what: str) -> str:
    """``value`` (a folder or file path as given, or resolved) if every character is one a shell passes
    through unchanged (:data:`PATH_PATTERN`), else a :class:`UsageError` naming ``what``."""
    text = str(value)
    if len(text) > PATH_MAX or _PATH.fullmatch(text) is None:
        raise UsageError(f"{what} {_shown(text)}: not allowed in a path the workflow passes to Snakemake (use {PATH_RULE})")
    return text
