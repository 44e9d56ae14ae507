"""Specific exceptions of tribo_bringup (graph runner, bags, CLI, report)."""


class BringupError(Exception):
    """Base class of tribo_bringup errors (the CLI answers them with exit code 2)."""


class BagError(BringupError):
    """A bag cannot be read or written (names the file and the last good message)."""


class BagTruncatedError(BagError):
    """A bag ends early or is corrupt after some good messages."""


class ConfigError(BringupError):
    """A configuration file or parameter is missing or invalid."""


class CampaignError(BringupError):
    """A campaign spec, store or query is invalid (names the file, key or statement)."""


class StoreBusyError(CampaignError):
    """Another campaign run holds the store (names the store and the holder's pid)."""
