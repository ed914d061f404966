"""The one exception for bad input: the CLI turns it into one line naming the field, and exit 2."""
from __future__ import annotations

__all__ = ["ConfigError"]


class ConfigError(ValueError):
    """A bad input: a configuration key or value, a flag, a path.

    Parameters
    ----------
    key : str
        The field at fault (a dotted configuration key, a flag such as ``--out``, or a path).
    message : str
        What is wrong and how to fix it, in one sentence.
    """

    def __init__(self, key: str, message: str):
        self.key = key
        super().__init__(f"{key}: {message}" if key else message)
