"""Specific exceptions of tribo_scenarios (scenario draws, simulation, cache, output files).

Every error names the problem (seed, key, value, file). The ``python -m tribo_scenarios``
command answers any :class:`ScenarioError` with one line on stderr and exit code 2.
"""

from __future__ import annotations


class ScenarioError(Exception):
    """Base class of all tribo_scenarios errors."""


class InvalidRequestError(ScenarioError, ValueError):
    """A draw request is out of the documented space (unknown family, kind, duration)."""


class SimulationError(ScenarioError, RuntimeError):
    """The integrator could not produce a record (step size underflow, event chatter)."""


class CacheError(ScenarioError, OSError):
    """A cached record is unreadable or belongs to another specification."""


class OutputError(ScenarioError, OSError):
    """A scenario's files (CSV, RIG.yaml, truth.json) cannot be written."""
