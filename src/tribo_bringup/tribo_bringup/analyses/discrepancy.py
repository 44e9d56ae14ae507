"""Analysis ``discrepancy``: the missing-physics workflow of ``tribo discrepancy``.

Reads the window of the session's rig streams (:func:`tribo_estimation.read_record`)
and calls :func:`tribo_estimation.find_missing_physics` with the command's defaults.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .base import AnalysisInputs, AnalysisResult

if TYPE_CHECKING:
    from tribo_estimation.results import MissingPhysics


#: The ``discrepancy.json`` keys the report shows (the file has them all).
SUMMARY_KEYS: tuple[str, ...] = (
    'verdict', 'reason', 'experiment', 'added', 'cannot_tell_apart', 'partial', 'baseline',
    'final', 'noise_floor',
)  # fmt: skip


class DiscrepancyAnalysis:
    """The missing-physics workflow on a window of a session (:mod:`.base`)."""

    name = 'discrepancy'
    title = 'Discrepancy workflow: missing physics (tribo discrepancy)'
    inputs: tuple[str, ...] = ('rig', '/rig/torsion_moment')
    on_request = True

    def call(self, inp: AnalysisInputs) -> str:
        """Return the library call in one line."""
        start, duration = inp.window
        rig = inp.rig.name if inp.rig is not None else '?'
        span = f'{duration:g} s' if duration > 0 else 'to the end'
        return (
            f'find_missing_physics(read_record({inp.source.name}, start {start:g} s, {span}), '
            f'rig of {rig})'
        )

    def run(self, inp: AnalysisInputs) -> MissingPhysics:
        """Read the window and run the workflow."""
        from tribo_estimation.api import find_missing_physics, read_record

        assert inp.rig is not None
        start, duration = inp.window
        rec = read_record(
            inp.source,
            inp.rig,
            start=start,
            duration=duration,
            keep_truncated=True,
            progress=inp.progress,
        )
        return find_missing_physics(rec, inp.rig, progress=lambda s: inp.progress(f'  {s}'))

    def summary(self, result: AnalysisResult) -> dict[str, object]:
        """Return the verdict and its evidence (``discrepancy.json`` keys), and the input's damage.

        The verdict, its reason and the experiment that would decide; the families named
        (``added``), the set the record cannot tell apart and the partial explanations;
        the baseline and the final model (torque residual rms [N m], values) and the noise
        floor [N m].
        """
        from tribo_estimation.results import MissingPhysics

        assert isinstance(result, MissingPhysics)
        data = result.as_dict()
        out: dict[str, object] = {k: data[k] for k in SUMMARY_KEYS if k in data}
        cut = result.inputs[0].truncated if result.inputs else ''
        if cut:
            out['input_truncated'] = cut
        return out

    def finding(self, result: AnalysisResult) -> str:
        """Return the verdict in one line (named families or the set, residual before and after)."""
        from tribo_estimation.results import MissingPhysics

        assert isinstance(result, MissingPhysics)
        return result.finding()


ANALYSIS = DiscrepancyAnalysis()
