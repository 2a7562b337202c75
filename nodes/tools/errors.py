"""The exceptions CLI verbs raise: each is printed as one line on stderr by the dispatcher."""


class UsageError(Exception):
    """Bad command-line input (exit status 2)."""


class Failed(Exception):
    """The command could not be done: no router, no such node or topic, a request declined (exit status 1)."""
