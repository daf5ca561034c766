"""Errors that are the user's to fix, and the stop that SIGTERM asks for."""


class UserError(Exception):
    """Bad input (a file, a field, a value): the message names them and what is allowed."""


class ParameterError(ValueError):
    """A parameter file is missing, malformed, or holds a value outside its allowed range."""


class Terminated(KeyboardInterrupt):
    """SIGTERM arrived: stop like Ctrl-C (a KeyboardInterrupt, so every `finally` that finishes
    a log on Ctrl-C does so here too)."""
