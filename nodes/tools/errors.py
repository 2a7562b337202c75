"""The one exception CLI verbs raise for bad input (printed as one line, exit status 2)."""


class UsageError(Exception):
    """Bad command-line input."""
