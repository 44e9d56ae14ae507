"""tribo_nvct: nVCT wear measurement (paper section 3).

The Python API (:mod:`tribo_nvct.api`), imported on first use (PEP 562) so that
``import tribo_nvct`` stays cheap:

- :func:`load_nvct`: read an NVCT.yaml;
- :func:`read_counts`: the dwells of a counts CSV or a bag -> :class:`Counts`;
- :func:`evaluate_wear`: counts to wear volume, running-in and progressive wear,
  k_w (Equ. 8-10) -> :class:`~.results.WearResult`.

Examples
--------
>>> import tribo_nvct as tn
>>> sorted(tn.__all__)
['Counts', 'WearResult', 'evaluate_wear', 'load_nvct', 'read_counts']
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from tribo_nvct.api import evaluate_wear, load_nvct, read_counts
    from tribo_nvct.core.countsio import Counts
    from tribo_nvct.results import WearResult

#: Public name -> module that defines it (PEP 562 lazy attributes).
_EXPORTS: dict[str, str] = {
    'load_nvct': 'tribo_nvct.api',
    'read_counts': 'tribo_nvct.api',
    'evaluate_wear': 'tribo_nvct.api',
    'Counts': 'tribo_nvct.core.countsio',
    'WearResult': 'tribo_nvct.results',
}

__all__ = ['Counts', 'WearResult', 'evaluate_wear', 'load_nvct', 'read_counts']


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
