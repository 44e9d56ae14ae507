"""Analysis ``friction``: the block-wise mu0/mu_inf fit of ``tribo friction`` (paper 2.5, Equ. 8).

Calls :func:`tribo_estimation.fit_blocks` on the session with the command's
defaults, so its ``blocks.csv`` equals ``tribo friction``'s on the same bag.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .base import AnalysisInputs, AnalysisResult

if TYPE_CHECKING:
    from tribo_estimation.results import BlockFit


class FrictionAnalysis:
    """The block fit of a session's rig streams (:mod:`tribo_bringup.analyses.base`)."""

    name = 'friction'
    title = 'Offline block-wise friction fit (tribo friction)'
    inputs: tuple[str, ...] = ('rig', '/rig/torsion_moment')
    on_request = False

    def call(self, inp: AnalysisInputs) -> str:
        """Return the library call in one line."""
        rig = inp.rig.name if inp.rig is not None else '?'
        return f'fit_blocks({inp.source.name}, rig of {rig}, block 1 s)'

    def run(self, inp: AnalysisInputs) -> BlockFit:
        """Fit the blocks; a bag that ends early gives the blocks before the damage."""
        from tribo_estimation.api import fit_blocks

        assert inp.rig is not None
        return fit_blocks(inp.source, inp.rig, keep_truncated=True)

    def summary(self, result: AnalysisResult) -> dict[str, object]:
        """Return the fit's headline numbers and the input's damage."""
        out: dict[str, object] = dict(result.summary())
        out['input_truncated'] = getattr(result, 'truncated', '') or None
        return out

    def finding(self, result: AnalysisResult) -> str:
        """Return '' (the friction section tells the story)."""
        return ''


ANALYSIS = FrictionAnalysis()
