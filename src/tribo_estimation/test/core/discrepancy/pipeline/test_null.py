"""The null law: Student-t prediction bounds of the replicas' log statistics, and the
replicas' refit by the record's estimator."""

from __future__ import annotations

import math

import numpy as np
import pytest
from discrepancy_scenarios import NOISE as LEVELS
from discrepancy_scenarios import constant, record, rpm
from scipy.stats import t as student_t
from tribo_scenarios.spec import DriveSpec, Transition

from tribo_estimation.core.discrepancy.fitting import K_DECAY, MU0, MU_INF
from tribo_estimation.core.discrepancy.pipeline.noise import ChannelNoise, NoiseModel
from tribo_estimation.core.discrepancy.pipeline.null import Adequacy, NullLaw, null_law, replica
from tribo_estimation.core.discrepancy.pipeline.policy import Policy
from tribo_estimation.core.discrepancy.pipeline.prepare import prepare
from tribo_estimation.core.model import DriveProfile

NOISE = NoiseModel(ChannelNoise(0.05), ChannelNoise(2.0), ChannelNoise(0.005))


def _law(alpha: float = 0.01) -> NullLaw:
    tq = (1.04, 1.05, 1.045, 1.06, 1.035, 1.05, 1.055, 1.04)
    return NullLaw({'torsion_moment': tq, 'speed': tq, 'blocks': tq}, alpha, (0.001, -0.002, 0.0))


def test_bound_is_the_t_prediction_bound_of_the_logs() -> None:
    law = _law()
    x = np.log(law.samples['torsion_moment'])
    q = student_t.ppf(1.0 - 0.01 / 3, x.size - 1)
    expected = math.exp(x.mean() + q * x.std(ddof=1) * math.sqrt(1.0 + 1.0 / x.size))
    assert law.bound('torsion_moment') == pytest.approx(expected, rel=1e-12)
    assert law.centre('torsion_moment') == pytest.approx(math.exp(x.mean()), rel=1e-12)


def test_failing_names_the_statistics_beyond_their_bounds() -> None:
    law = _law()
    b = law.bound('speed')
    inside = Adequacy({'torsion_moment': 1.0, 'speed': 0.99 * b, 'blocks': 1.0}, NOISE)
    outside = Adequacy({'torsion_moment': 1.0, 'speed': 1.01 * b, 'blocks': 1.0}, NOISE)
    assert law.failing(inside) == ()
    assert law.failing(outside) == ('speed',)


def test_a_smaller_alpha_widens_the_bound() -> None:
    assert _law(0.001).bound('blocks') > _law(0.05).bound('blocks')


def test_drift_outlier_is_two_sided_around_the_replicas() -> None:
    law = _law()
    x = np.asarray(law.drifts)
    q = student_t.ppf(1.0 - 0.01 / 2, x.size - 1)
    half = q * x.std(ddof=1) * math.sqrt(1.0 + 1.0 / x.size)
    assert not law.drift_outlier(float(x.mean() + 0.99 * half))
    assert law.drift_outlier(float(x.mean() + 1.01 * half))
    assert law.drift_outlier(float(x.mean() - 1.01 * half))


def test_without_two_replicas_there_is_no_law_and_nothing_is_adequate() -> None:
    law = NullLaw({'torsion_moment': (1.05,)}, 0.01)
    assert math.isnan(law.bound('torsion_moment'))
    fit = Adequacy({'torsion_moment': 1.0}, NOISE)
    assert law.failing(fit) == ('torsion_moment',)


def test_a_pooled_law_keeps_its_own_replicas_and_the_newest_earlier_ones() -> None:
    new = NullLaw({'torsion_moment': (1.1, 1.2), 'speed': (2.1, 2.2)}, 0.01, (0.1, 0.2))
    old = NullLaw(
        {'torsion_moment': (1.3, 1.4, 1.5, 1.6), 'speed': (2.3, 2.4, 2.5, 2.6)}, 0.05, (0.3,) * 4
    )
    law = new.pooled(old, 5)
    # this window's two first, then the three newest of the earlier windows; this alpha
    assert law.samples == {
        'torsion_moment': (1.1, 1.2, 1.3, 1.4, 1.5),
        'speed': (2.1, 2.2, 2.3, 2.4, 2.5),
    }
    assert law.drifts == (0.1, 0.2, 0.3, 0.3, 0.3) and law.alpha == 0.01
    # never fewer than its own replicas
    assert new.pooled(old, 1).samples == new.samples


@pytest.mark.parametrize(('own_error', 'usable'), [(0.0, True), (0.9, True), (1.1, False)])
def test_a_law_whose_replicas_refit_beyond_their_noise_is_not_self_consistent(
    own_error: float, usable: bool
) -> None:
    # replicas refitted to sqrt(1 + e^2) x their noise for the workflow's own error e
    # [noise units]: usable while e is below the noise
    rng = np.random.default_rng(5)
    centre = math.sqrt(1.0 + own_error**2)
    tq = tuple(centre * (1.0 + 0.005 * rng.standard_normal(8)))
    law = NullLaw({'torsion_moment': tq, 'speed': tq, 'blocks': tq}, 0.01)
    assert law.self_consistent() is usable


def test_the_replicas_are_weighted_by_their_own_residuals() -> None:
    # the record's estimator weighs each channel by its residual at the model; so are
    # the replicas, whatever the record's weights were (they carry the record's own
    # misfit: a torque residual of 18x its noise weighed a replica's torque 35x below
    # its noise, and the refit traded it for the speed channel). Same seed, the record's
    # torque weight 1000x lower: the same statistics within 1e-9
    rec, rig, drv = record(4, constant(rpm(20)), fs=5000.0, duration=1.0)
    pb = prepare(rec, rig, drv, k=2.0, policy=Policy(shaft=False)).problem
    noise = NoiseModel(*(ChannelNoise(s) for s in LEVELS))
    values = {'mu0': 0.13, 'mu_inf': 0.10, 'k': 2.0}

    def law() -> NullLaw:
        return null_law(pb, values, [MU0, MU_INF, K_DECAY], noise, replicas=2, alpha=0.01,
                        seed=1, max_nfev=20)  # fmt: skip

    first = law()
    pb.weights['torsion_moment'] *= 1e-3
    again = law()
    for name, got in again.samples.items():
        assert got == pytest.approx(first.samples[name], rel=1e-9), name
    assert first.centre('torsion_moment') < 1.2  # replicas of the true model


def test_a_replica_of_a_record_from_the_drive_start_begins_there() -> None:
    # a record from the drive's start (a 0.3 s start-up ramp to 25 rpm in RIG.yaml, at
    # rest at its first sample, 5 kHz): its replica begins at the first sample too,
    # holding the model's first segment state until then. Its problem then starts the
    # drive profile from rest at t = 0 and a segment at the initial stick from rest, as
    # the record's does (begun at the first segment, 3 ms later and moving, its profile
    # began at 0.026 rad/s and its first segment came after the initial stick, 0.115 s
    # later); its replicas refit their own model at the noise (median below 1.05x)
    speed = rpm(25)
    drive = DriveSpec('startup', (Transition(0.0, 0.3, speed, 'linear'),), 0.0, speed, 0.3,
                      ('startup',))  # fmt: skip
    rec, rig, _ = record(3, drive, fs=5000.0, duration=2.0)
    pb = prepare(rec, rig, DriveProfile(speed, 0.3), k=2.0, policy=Policy(shaft=False)).problem
    assert pb.begins_at_drive_start
    values = {'mu0': 0.13, 'mu_inf': 0.10, 'k': 2.0}
    rep = pb.like(replica(pb, values, NOISE, np.random.default_rng(0)))
    assert rep.record.time[0] == rec.time[0] == 0.0
    assert rep.begins_at_drive_start
    # the same first segments (samples) and the profile from rest at t = 0
    assert rep.segments.start[:3].tolist() == pb.segments.start[:3].tolist()
    assert rep.drive_estimate.knot_time[0] == 0.0
    assert rep.drive_estimate.knot_speed[0] == 0.0
    law = null_law(pb, values, [MU0, MU_INF, K_DECAY], NOISE, replicas=4, alpha=0.01, seed=2,
                   max_nfev=20)  # fmt: skip
    assert float(np.median(law.samples['torsion_moment'])) < 1.05, law.samples
