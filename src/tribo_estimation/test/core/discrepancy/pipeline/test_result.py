"""The one-line finding of the pipeline's result (pipeline/result.py)."""

from __future__ import annotations

from tribo_estimation.core.discrepancy.pipeline import Effect, MissingPhysics, Policy
from tribo_estimation.core.discrepancy.pipeline.decide import UNEXPLAINED
from tribo_estimation.core.discrepancy.pipeline.null import NullLaw
from tribo_estimation.core.discrepancy.pipeline.result import RecordReport


def _result(verdict: str, effects: tuple[Effect, ...]) -> MissingPhysics:
    law = NullLaw({'torsion_moment': (1.03, 1.05, 1.04), 'speed': (1.0, 1.02, 1.01)}, 0.01)
    rep = RecordReport(
        baseline={'mu0': 0.13, 'mu_inf': 0.1}, final={'mu0': 0.13, 'mu_inf': 0.1},
        rms_baseline=0.396, rms_final=0.396, noise_floor=0.05,
        statistics_baseline={'torsion_moment': 8.9}, statistics_final={'torsion_moment': 8.9},
        null=law, noise={}, instrument={}, drive={}, drift_outlier=False,
    )  # fmt: skip
    return MissingPhysics(
        verdict=verdict, reason='no family explains the mismatch down to the noise',
        experiment=None, named=(), alternatives=effects, partial=effects, records=(rep,),
        rounds=(effects,), policy=Policy(), run_time=1.0, simulations=10,
    )  # fmt: skip


def test_an_unexplained_set_reports_how_far_each_member_gets() -> None:
    # nothing is added to the model, so baseline and final rms agree; the line must
    # still say that the kept form takes the residual from 0.396 to 0.0887 N m
    visc = Effect('viscous_friction', 'viscous_friction', {'c_visc': 0.8}, {'c_visc': 0.01},
                  {'c_visc': 'N m s/rad'}, (0.0887,), (1.77,), 0.97)  # fmt: skip
    line = _result(UNEXPLAINED, (visc,)).finding()
    assert line.startswith('not explained: {viscous_friction}'), line
    assert 'torque residual RMS 0.396 N m' in line, line
    assert 'with viscous_friction 0.0887 (97 % of the excess)' in line, line
    assert '0.396 -> 0.396' not in line, line
