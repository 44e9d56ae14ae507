"""Dwell-time stiction on records of the independent generator: its parameters and verdict.

Records come from the independent reference generator (core/reference.py,
core/reference_records.py: scipy DOP853, its own equations, config/rig.yaml noise),
never from the project's kernel. A speed step (15 -> 35 rpm) changes the stick
durations, which decides dwell-time stiction; the fitted gain and time constant must
be within 20 % of the truth. The helpers behind it are checked on analytic cases: a
stick phase the record start cuts (unknown dwell) is not fitted, the profile's
parabola finds the minimum of a parabola, and a fit that moves far while polishing is
called unstable. The model-error term of the standard errors (the leverage-corrected
block sandwich) is the block jackknife of a linear fit.
"""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from tribo_estimation.core.config import load_rig_config
from tribo_estimation.core.discrepancy import candidates as cand_lib
from tribo_estimation.core.discrepancy.fitting import (
    UNKNOWN_DWELL,
    Record,
    begins_at_drive_start,
    make_segments,
    stick_runs,
    stuck_before_onset,
)
from tribo_estimation.core.discrepancy.identify import GaussNewton, fit_stability
from tribo_estimation.core.discrepancy.linearised import _block_robust_sd
from tribo_estimation.core.discrepancy.select import SelectionSettings, run_discrepancy
from tribo_estimation.core.discrepancy.select.scoring import Selector, _profile_vertex
from tribo_estimation.core.model import DriveProfile, Extensions
from tribo_estimation.core.reference import SpeedProfile
from tribo_estimation.core.reference_records import RecordSpec, make_record, rig_channels, rpm

CFG = load_rig_config(Path(__file__).resolve().parents[3] / 'config' / 'rig.yaml')
#: The hidden effect (config/rig_hidden_dwell_time_stiction.yaml): gain [-], tau [s].
GAIN, TAU = 0.02, 0.005


def _step_record(seed: int, duration: float, start: float = 0.5) -> Record:
    """A 15 -> 35 rpm speed step in the middle of the record, ``start`` s after the drive start."""
    tc, ac, sc = rig_channels(1.0)
    prof = SpeedProfile.steps([rpm(15), rpm(35)], [start + duration / 2])
    r = make_record(RecordSpec(CFG.rig, CFG.friction, prof,
                               extensions=Extensions(stiction_gain=GAIN, stiction_tau=TAU),
                               torsion=tc, accel=ac, speed=sc, seed=seed, duration=duration,
                               start_offset=start))  # fmt: skip
    return Record(r.time - r.time[0], r.torsion_moment, r.angular_acceleration, r.speed)


def test_dwell_time_stiction_on_a_speed_step_within_20_percent() -> None:
    """The speed step decides dwell-time stiction: named, identifiable on its converged
    fit, gain and tau within 20 % (tolerance of the issue; the bench's 'step' record,
    seed 1010: before the profile screening the fit crawled along the mu0-gain-tau
    valley and stopped at gain 0.0152, tau 6.7 ms, 24 % and 34 % off; now ~2 %)."""
    rec = _step_record(seed=1010, duration=3.0)
    st = SelectionSettings(candidates=('dwell_time_stiction',), max_effects=1, propose_terms=False)
    res = run_discrepancy(rec, CFG.rig, DriveProfile(rpm(15), 0.0), k=CFG.friction.k, settings=st)
    assert [a.effect for a in res.added] == ['dwell_time_stiction']
    assert res.identifiable['dwell_time_stiction'].ok
    p = res.added[0].params
    assert p['stiction_gain'] == pytest.approx(GAIN, rel=0.2)
    assert p['stiction_tau'] == pytest.approx(TAU, rel=0.2)
    # the fit removes the effect: residual within 1.5x the noise floor (0.05 N m)
    assert res.added[0].rms_after < 1.5 * 0.05


def test_stick_cut_by_the_record_start_is_not_fitted() -> None:
    """A record that starts inside a stick phase does not know that stick's dwell: no
    segment starts in it, and it is listed with the reason; a record that begins at the
    drive's start from rest knows it (the stick began with the record)."""
    rec = _step_record(seed=5, duration=0.4)
    segs = make_segments(rec, CFG.rig)
    assert not begins_at_drive_start(rec, 0.0, rpm(15))
    first, _, _ = stick_runs(rec, CFG.rig)
    assert int(first[0]) == 0  # this record (seed 5) starts inside a stick phase
    assert [why for _, why in segs.rejected].count(UNKNOWN_DWELL) == 1
    assert segs.run_start is not None and int(segs.run_start[0]) == int(first[1])
    kept = make_segments(rec, CFG.rig, dwell_from_start=True)
    assert not any(why == UNKNOWN_DWELL for _, why in kept.rejected)
    assert kept.n >= segs.n


def test_profile_vertex_of_a_parabola() -> None:
    """Three points of cost = (ln tau - ln 5 ms)^2 give the vertex 5 ms exactly (1e-9);
    a minimum at the grid's end or a profile curving down gives none."""
    spec = cand_lib.get('dwell_time_stiction').params[1]

    def cost(v: float) -> float:
        return (math.log(v) - math.log(TAU)) ** 2

    grid = [0.001, 0.003, 0.008, 0.03]
    pts: list[tuple[float, float, dict[str, float]]] = [(v, cost(v), {}) for v in grid]
    v = _profile_vertex(pts, spec)
    assert v is not None and v == pytest.approx(TAU, rel=1e-9)
    assert _profile_vertex([(x, -cost(x), {}) for x in grid], spec) is None
    assert _profile_vertex([(x, x, {}) for x in grid], spec) is None  # best at the end


def test_unstable_fit_is_not_identified() -> None:
    """A parameter that moved 30 % and 30 SE between the round's fit and the converged
    one is an unstable fit; 3 % (below the 10 % floor) or 2 SE is not."""
    names = ('mu0', 'mu_inf', 'stiction_gain', 'stiction_tau')
    gn = GaussNewton(names, (0.13, 0.1, 0.02, 0.005), (1e-4, 1e-4, 2e-4, 5e-5), np.eye(4), ())
    moved = fit_stability('dwell_time_stiction', names[2:], gn,
                          {'stiction_gain': 0.02, 'stiction_tau': 0.0065})  # fmt: skip
    assert moved is not None and not moved.ok
    assert 'unstable fit' in moved.reason and 'stiction_tau' in moved.reason
    assert moved.suggest == 'a second drive speed or a speed step'
    small = {'stiction_gain': 0.0206, 'stiction_tau': 0.00515}  # 3 %, > 3 SE
    assert fit_stability('dwell_time_stiction', names[2:], gn, small) is None
    gn_wide = GaussNewton(names, gn.values, (1e-4, 1e-4, 2e-2, 5e-3), np.eye(4), ())
    assert fit_stability('dwell_time_stiction', names[2:], gn_wide,
                         {'stiction_gain': 0.03, 'stiction_tau': 0.0065}) is None  # fmt: skip


def test_block_robust_term_is_the_block_jackknife_of_a_linear_fit() -> None:
    """For a linear least-squares fit the leverage-corrected block sandwich equals the
    leave-one-block-out jackknife exactly, sqrt((G-1)/G * sum_b (theta_b - theta)^2)
    (rel. 1e-9), seeded data with a trend parameter that the end blocks dominate."""
    rng = np.random.default_rng(12)
    t = np.linspace(0.0, 3.0, 600)
    blocks = np.minimum((t / 0.25).astype(np.int64), 11)
    x = np.vstack([np.ones_like(t), t])  # parameters: level, trend (rows of J = -X)
    y = 0.3 + 0.05 * t + rng.normal(0.0, 0.1, t.size) + 0.05 * np.sin(7.0 * t)
    theta = np.linalg.lstsq(x.T, y, rcond=None)[0]
    r0 = y - theta @ x
    jac = -x
    a_inv = np.asarray(np.linalg.inv(jac @ jac.T), dtype=np.float64)
    sd = _block_robust_sd(jac, r0, a_inv, blocks)
    g_n = int(blocks.max()) + 1
    loo = np.array(
        [np.linalg.lstsq(x[:, blocks != b].T, y[blocks != b], rcond=None)[0] for b in range(g_n)]
    )
    jack = np.sqrt((g_n - 1) / g_n * np.sum((loo - theta) ** 2, axis=0))
    np.testing.assert_allclose(sd, jack, rtol=1e-9)


def test_stick_dated_late_by_the_detector_is_not_a_segment_start() -> None:
    """A (noise-free) speed-step record in which the stick detector dates the stick that
    begins 5.8 ms before the drive ramp (15 -> 35 rpm at 2.0 s) to the ramp's start:
    the shaft and chamber speeds agree that far before the detected onset (within
    0.5 ms of the reference's event log), so no segment starts there (its dwell is
    unknown); the other sticks' onsets are right (< 0.5 ms early)."""
    tc, ac, sc = rig_channels(1e-3)
    prof = SpeedProfile.steps([rpm(15), rpm(35)], [2.0])
    r = make_record(RecordSpec(CFG.rig, CFG.friction, prof,
                               extensions=Extensions(stiction_gain=GAIN, stiction_tau=TAU),
                               torsion=tc, accel=ac, speed=sc, seed=1010, duration=0.3,
                               start_offset=1.85))  # fmt: skip
    rec = Record(r.time - r.time[0], r.torsion_moment, r.angular_acceleration, r.speed)
    a, b, onset = stick_runs(rec, CFG.rig)
    true_onsets = np.array([s for s, _ in r.sticks]) - float(r.time[0])
    late = np.array([float(np.min(np.abs(true_onsets - o))) for o in onset])
    early = stuck_before_onset(rec, CFG.rig, a, b)
    k = int(np.argmax(late))
    assert late[k] > 5e-3  # s: the detector's late onset at the ramp start
    assert early[k] == pytest.approx(late[k], abs=5e-4)
    assert np.all(np.delete(early, k) < 5e-4)
    segs = make_segments(rec, CFG.rig)
    assert int(a[k]) not in {int(x) for x in np.asarray(segs.run_start)}
    assert any('before its detected onset' in why for _, why in segs.rejected)


def test_profile_standard_error_from_its_curvature() -> None:
    """A profile cost = c0 + q*(ln tau - ln 5 ms)^2 along which the gain moves by
    dg/d(ln tau) = -0.01: SE(ln tau) = sqrt(c0*c/(m*q)) (m residual elements, c the
    samples per correlation time) and SE(gain) = 0.01*SE(ln tau), to 1e-9."""
    n, fs, c0, q = 20_000, 10_000.0, 0.006, 0.05
    pb = SimpleNamespace(
        weights={'torsion_moment': 1.0, 'chamber_speed': 1.0, 'speed': 1.0},
        segments=SimpleNamespace(sample_mask=lambda size: np.ones(n, dtype=bool)),
        record=SimpleNamespace(time=np.zeros(n), fs=fs),
    )
    sel = SimpleNamespace(pb=pb, st=SelectionSettings(corr_time=1e-3))
    grid = [0.003, 0.0045, 0.005, 0.0055, 0.008]
    screened = [
        (v, c0 + q * math.log(v / TAU) ** 2, {'stiction_gain': 0.02 - 0.01 * math.log(v / TAU)})
        for v in grid
    ]
    se = Selector._profile_se(sel, screened, c0, 'stiction_tau')
    se_x = math.sqrt(c0 * 10.0 / (3 * n * q))
    assert se['stiction_tau'] == pytest.approx(TAU * se_x, rel=1e-9)
    assert se['stiction_gain'] == pytest.approx(0.01 * se_x, rel=1e-9)
