"""Errors that are the user's to fix: the command line prints them without a traceback."""


class UserError(Exception):
    """Bad input (a file, a field, a value): the message names them and what is allowed."""
