"""One module per candidate effect (auto-discovered).

Importing this package imports every module in it; each module registers its
:class:`~tribo_estimation.core.discrepancy.candidates.Candidate` with
:func:`~tribo_estimation.core.discrepancy.candidates.register`. A new candidate
is therefore one new file here: its parameters (``Extensions`` fields, used by
the kernel through its generic hooks, see docs/physics.md section 8), its
localiser, its start values, its help text (``description``) and its demo
configuration (``demo_effects``). The registry, the CLI help of
``tribo discrepancy`` and the choices of ``tribo demo --effect`` follow.
"""

from __future__ import annotations

import importlib
import pkgutil

#: Modules imported (and so registered) by this package, in import order.
DISCOVERED: tuple[str, ...] = tuple(
    sorted(m.name for m in pkgutil.iter_modules(__path__) if not m.name.startswith('_'))
)

for _name in DISCOVERED:
    importlib.import_module(f'{__name__}.{_name}')
