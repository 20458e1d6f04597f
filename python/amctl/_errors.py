"""The exceptions of amctl (the three error channels of docs/architecture.md)."""


class Error(Exception):
    """Bad input: a malformed file, an out-of-range value, an unknown key.

    Raised for every ``amctl::Error`` of the C++ library. ``str(e)`` is the message the
    command line prints (``FILE:LINE:COL: what was found, what was expected``).

    Attributes:
        file:   the input file the error is in, or None when it is not about a file.
        line:   1-based line in that file, or None when unknown.
        column: 1-based column in that line, or None when unknown.
        detail: the message without the ``file:line:col:`` prefix.
    """

    def __init__(self, message, file=None, line=None, column=None, detail=None):
        super().__init__(message)
        self.file = file
        self.line = line
        self.column = column
        self.detail = message if detail is None else detail


class InternalError(RuntimeError):
    """A broken internal invariant of amctl (``amctl::InternalError``): a bug, never the
    caller's fault. Please report it with the input that caused it."""
