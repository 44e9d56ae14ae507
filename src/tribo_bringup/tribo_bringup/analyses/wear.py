"""Analysis ``wear``: the nVCT evaluation of ``tribo wear`` (paper section 3, Equ. 8-10).

Calls :func:`tribo_nvct.evaluate_wear` on the session's ``/nvct/counts``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .base import AnalysisInputs, AnalysisResult

if TYPE_CHECKING:
    from tribo_nvct.results import WearResult


class WearAnalysis:
    """The wear evaluation of a session's detector counts (:mod:`.base`)."""

    name = 'wear'
    title = 'Offline nVCT wear evaluation (tribo wear)'
    inputs: tuple[str, ...] = ('nvct', '/nvct/counts')
    on_request = False

    def call(self, inp: AnalysisInputs) -> str:
        """Return the library call in one line."""
        nvct = inp.nvct.name if inp.nvct is not None else '?'
        return f'evaluate_wear(read_counts({inp.source.name}), config {nvct})'

    def run(self, inp: AnalysisInputs) -> WearResult:
        """Evaluate the counts; a bag that ends early gives the dwells before the damage."""
        from tribo_nvct.api import evaluate_wear, read_counts

        assert inp.nvct is not None
        return evaluate_wear(read_counts(inp.source, keep_truncated=True), inp.nvct)

    def summary(self, result: AnalysisResult) -> dict[str, object]:
        """Return the evaluation's numbers (summary.json)."""
        return dict(result.summary())

    def finding(self, result: AnalysisResult) -> str:
        """Return '' (the wear section tells the story)."""
        return ''


ANALYSIS = WearAnalysis()
