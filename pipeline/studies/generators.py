"""Problem-set generators by name: the one place a study's ``generator`` string becomes a function.

:mod:`pipeline.problems` holds the registry of names (:data:`pipeline.problems.GENERATORS`) and checks
them; the functions are study code (``pipeline.studies.<id>.problems``), a layer above it, so they are
imported here and handed to :func:`pipeline.problems.make_problem_set` as its ``load`` argument.
"""

from __future__ import annotations

import importlib

from pipeline.problems import Generator, ProblemSpecError, check_generator


def load_generator(ref: str) -> Generator:
    """The registered generator ``"pipeline.studies.<id>.<module>:<function>"``.

    Parameters
    ----------
    ref : str
        One of :data:`pipeline.problems.GENERATORS`.

    Returns
    -------
    Generator
        ``f(model, count, rng, params, data_dir) -> ProblemSet``.

    Raises
    ------
    ProblemSpecError
        A name not in the registry, or one that cannot be imported (one line naming the field).
    """
    mod, _, fn = check_generator(ref).partition(":")
    try:
        return getattr(importlib.import_module(mod), fn)
    except (ImportError, AttributeError) as exc:
        raise ProblemSpecError(f"field 'generator': cannot load {ref!r} ({exc})") from None
