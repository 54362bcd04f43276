"""The one usage error every layer may raise (a one-line message; the CLI prints it as ``error: ...``)."""


class UsageError(Exception):
    """A usage problem found after parsing: a wrong argument, a set or solver a study does not have."""
