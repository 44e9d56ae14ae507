"""Missing-physics (discrepancy) workflow.

Find where the rig model (the paper's Equ. 1-8) and a measured record disagree,
name the missing effect from a library of nested model extensions, add it, and
show the gap shrink; describe what no candidate explains.

Modules: :mod:`.stats` (residual statistics), :mod:`.localise` (where the gap
concentrates), :mod:`.candidates` (the pluggable library), :mod:`.fitting`
(segment-wise output-error fit), :mod:`.select` (cross-validated, BIC-checked
forward selection), :mod:`.identify` (can the record separate an effect?),
:mod:`.joint` (several records at once), :mod:`.monitor` (live rolling window),
:mod:`.sparse` (SINDy-style proposal), :mod:`.report` (``discrepancy.json``),
:mod:`.plots` (PNG figures).
"""

from .joint import JointResult, run_joint_discrepancy
from .select import DiscrepancyResult, SelectionSettings, run_discrepancy

__all__ = [
    'DiscrepancyResult',
    'JointResult',
    'SelectionSettings',
    'run_discrepancy',
    'run_joint_discrepancy',
]
