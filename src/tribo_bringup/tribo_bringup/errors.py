"""Specific exceptions of tribo_bringup (graph runner, CLI, report).

The bag errors live with the bag reader in :mod:`tribo_common.errors` (the
analyses of the lower packages read bags too) and are re-exported here.
"""

from tribo_common.errors import BagError as BagError
from tribo_common.errors import BagTruncatedError as BagTruncatedError


class BringupError(Exception):
    """Base class of tribo_bringup errors (the CLI answers them with exit code 2)."""


class ConfigError(BringupError):
    """A configuration file or parameter is missing or invalid."""


class CampaignError(BringupError):
    """A campaign spec, store or query is invalid (names the file, key or statement)."""


class StoreBusyError(CampaignError):
    """Another campaign run holds the store (names the store and the holder's pid)."""
