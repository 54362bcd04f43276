"""The one usage error every layer may raise (a one-line message; the CLI prints it as ``error: ...``)."""


class UsageError(Exception):
    """A usage problem found after parsing: a wrong argument, a set or solver a study does not have."""


def not_regular(path) -> str | None:
    """Why ``path`` is not a regular file one may read without blocking (a FIFO, a device, a socket), or None
    (a regular file, a directory, or nothing there: the caller reports those in its own words)."""
    import os
    import stat

    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):  # missing, unreadable, a NUL in the name
        return None
    if stat.S_ISREG(mode) or stat.S_ISDIR(mode):
        return None
    kind = ("a FIFO" if stat.S_ISFIFO(mode) else "a character device" if stat.S_ISCHR(mode) else
            "a block device" if stat.S_ISBLK(mode) else "a socket" if stat.S_ISSOCK(mode) else "not a file")
    return f"not a regular file ({kind}); give a file"
