"""tribo_estimation: the stick-slip rig's model, simulator and fits (paper sections 2.3-2.5).

The Python API (:mod:`tribo_estimation.api`), imported on first use so that
``import tribo_estimation`` stays cheap (no numba, scipy or matplotlib):

- :func:`load_rig`: read a RIG.yaml;
- :func:`read_record`: a rig CSV or bag through the input checks into one
  :class:`RigRecord`;
- :func:`fit_blocks`: block-wise mu0/mu_inf (Equ. 8) -> :class:`~.results.BlockFit`;
- :func:`find_missing_physics`: the missing-physics workflow ->
  :class:`~.results.MissingPhysics`;
- :func:`identify_decay`: I1, K1, C1 from a free decay (Equ. 7) ->
  :class:`~.results.DecayFit`;
- :func:`simulate`: the rig of a config -> a record with the truth.

Examples
--------
>>> import tribo_estimation as te
>>> sorted(te.__all__)[:3]
['BlockFit', 'DecayFit', 'MissingPhysics']
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from tribo_estimation.api import (
        find_missing_physics,
        fit_blocks,
        identify_decay,
        load_rig,
        read_record,
        simulate,
    )
    from tribo_estimation.core.record import InputFindings, RigRecord
    from tribo_estimation.results import BlockFit, DecayFit, MissingPhysics

#: Public name -> module that defines it (PEP 562 lazy attributes).
_EXPORTS: dict[str, str] = {
    'load_rig': 'tribo_estimation.api',
    'read_record': 'tribo_estimation.api',
    'fit_blocks': 'tribo_estimation.api',
    'find_missing_physics': 'tribo_estimation.api',
    'identify_decay': 'tribo_estimation.api',
    'simulate': 'tribo_estimation.api',
    'RigRecord': 'tribo_estimation.core.record',
    'InputFindings': 'tribo_estimation.core.record',
    'BlockFit': 'tribo_estimation.results',
    'MissingPhysics': 'tribo_estimation.results',
    'DecayFit': 'tribo_estimation.results',
}

__all__ = [
    'BlockFit',
    'DecayFit',
    'InputFindings',
    'MissingPhysics',
    'RigRecord',
    'find_missing_physics',
    'fit_blocks',
    'identify_decay',
    'load_rig',
    'read_record',
    'simulate',
]


def __getattr__(name: str) -> object:
    """Import a public name of the API on first access (PEP 562).

    Parameters
    ----------
    name : str
        The attribute.

    Returns
    -------
    object
        The function or class.

    Raises
    ------
    AttributeError
        ``name`` is not part of the API.
    """
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    """Return the public names (for completion)."""
    return sorted({*globals(), *_EXPORTS})
