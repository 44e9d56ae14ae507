"""The analyses of a recorded session, behind one protocol (:mod:`.base`).

One module per analysis, each with one ``ANALYSIS`` object; :data:`MODULES` is the
registry (in the order the report shows them). A new analysis the report shows is
one module here, its name in :data:`MODULES`, and its test: the report runs every
registered analysis that is not ``on_request`` (:func:`defaults`).
"""

from __future__ import annotations

import importlib
from functools import cache

from .base import Analysis, AnalysisInputs, AnalysisResult, missing, write

#: Registered analyses: name -> module of this package (report order).
MODULES: dict[str, str] = {
    'friction': 'friction',
    'wear': 'wear',
    'discrepancy': 'discrepancy',
}


@cache
def get(name: str) -> Analysis:
    """Return the registered analysis ``name``.

    Parameters
    ----------
    name : str
        A key of :data:`MODULES`.

    Returns
    -------
    Analysis
        Its ``ANALYSIS`` object.

    Raises
    ------
    KeyError
        ``name`` is not registered.
    """
    mod = importlib.import_module(f'{__name__}.{MODULES[name]}')
    analysis: Analysis = mod.ANALYSIS
    return analysis


def names() -> tuple[str, ...]:
    """Return the registered analyses' names, in report order."""
    return tuple(MODULES)


def defaults() -> tuple[str, ...]:
    """Return the analyses a report runs unless told otherwise (not ``on_request``)."""
    return tuple(n for n in MODULES if not get(n).on_request)


__all__ = [
    'MODULES',
    'Analysis',
    'AnalysisInputs',
    'AnalysisResult',
    'defaults',
    'get',
    'missing',
    'names',
    'write',
]
