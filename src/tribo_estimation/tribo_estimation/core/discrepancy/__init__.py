"""Missing-physics (discrepancy) workflow.

Find where the rig model (the paper's Equ. 1-8) and a measured record disagree,
name the missing effect from a library of nested model extensions (effect families,
each with the forms its physics allows), add it, and show the gap shrink; say when
the record cannot decide and which experiment would; describe what no candidate
explains.

Modules: :mod:`.pipeline` (prepare -> baseline -> null law -> screen -> decide, for
one record, several and the live window), :mod:`.fitting` (the segment-wise
output-error fit and the instrument chain), :mod:`.candidates` (the pluggable
library; one module per effect under :mod:`.effects`), :mod:`.stats` (residual
statistics), :mod:`.localise` (where the gap concentrates), :mod:`.monitor` (live
rolling window), :mod:`.sparse` (SINDy-style proposal), :mod:`.report`
(``discrepancy.json``), :mod:`.plots` (PNG figures).
"""

from .pipeline import KINDS, MissingPhysics, Policy, find_missing_physics

__all__ = ['KINDS', 'MissingPhysics', 'Policy', 'find_missing_physics']
