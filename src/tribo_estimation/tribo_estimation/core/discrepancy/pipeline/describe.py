"""Where and how large: the drive profile report, and what no candidate explains.

:func:`drive_report` is the measured drive profile of ``discrepancy.json``;
:func:`describe_unexplained` reports the residual structure a model leaves
(spectral lines, a phase-concentrated excess, a trend, a time block, a shaft-angle
dependence), each with where, how large and which frequency, rather than forcing a
name; :func:`propose_terms` fits a data-driven term (sparse regression,
:mod:`..sparse`) as a hint. These describe; they decide nothing (the decisions are
:mod:`.decide`'s).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..fitting import Problem, SimulatedRecord
from ..localise import shaft_angle, torque_residual
from ..sparse import SparseTerm, feature_library, stlsq
from ..stats import (
    PHASE_NAMES,
    angle_dependence,
    noise_floor,
    phase_labels,
    rms,
    spectral_lines,
    trend,
)


@dataclass(frozen=True)
class Unexplained:
    """Residual structure no candidate explains.

    ``kind`` one of 'spectral_line', 'phase', 'trend', 'time', 'shaft_angle',
    'broadband', 'instrument' (the stick kinematics drift: the rig or a sensor
    changes during the record); ``where`` says where it concentrates; ``size`` its
    magnitude (N m: line amplitude, phase excess rms, trend change over the record,
    excess rms of the worst time block, angle-harmonic amplitude; for 'instrument'
    the torque residual's rms it leaves); ``frequency`` Hz for lines (else None).
    """

    kind: str
    where: str
    size: float
    frequency: float | None = None
    details: dict[str, float] = field(default_factory=dict)

    def as_dict(self) -> dict[str, object]:
        """Return the JSON-ready form.

        Returns
        -------
        dict[str, object]
            Kind, where, size [N m], unit, frequency [Hz] and the details.
        """
        return {
            'kind': self.kind,
            'where': self.where,
            'size': self.size,
            'unit': 'N m',
            'frequency': self.frequency,
            **dict(self.details.items()),
        }


def block_speeds(pb: Problem) -> list[dict[str, float]]:
    """Return the mean drive speed of every time block.

    Parameters
    ----------
    pb : Problem
        The record's fit problem.

    Returns
    -------
    list[dict[str, float]]
        Per block: ``block`` index, ``t_start`` / ``t_end`` [s], mean drive speed
        ``w0`` [rad/s] of the measured profile.
    """
    de = pb.drive_estimate
    seg = pb.segments
    t = pb.record.time
    blocks = []
    for b in range(seg.n_blocks):
        m = seg.block == b
        t0 = float(t[seg.start[m][0]])
        t1 = float(t[min(int(seg.stop[m][-1]), t.size - 1)])
        blocks.append({'block': float(b), 't_start': t0, 't_end': t1, 'w0': de.mean_speed(t0, t1)})
    return blocks


def drive_report(pb: Problem) -> dict[str, object]:
    """Return the measured drive profile for ``discrepancy.json``.

    Parameters
    ----------
    pb : Problem
        The record's fit problem.

    Returns
    -------
    dict[str, object]
        Level and nominal speed [rad/s], relative mismatch [-] and its warning, the
        knots of the piecewise-linear profile [s, rad/s], the speed steps timed by the
        torsion moment (mid-time and duration [s],
        :meth:`..fitting.Problem.set_transition_durations`) and the mean drive speed
        used per time block [rad/s].
    """
    de = pb.drive_estimate
    blocks: list[dict[str, object]] = [
        {'block': int(b['block']), 't_start': b['t_start'], 't_end': b['t_end'], 'w0': b['w0']}
        for b in block_speeds(pb)
    ]
    return {
        'level': de.level,
        'nominal': de.nominal,
        'mismatch': de.mismatch,
        'mismatched': de.mismatched,
        'warning': de.warning() or '',
        'from_record': de.from_record,
        'knot_time': [float(x) for x in de.knot_time],
        'knot_speed': [float(x) for x in de.knot_speed],
        'timed_steps': [
            {'mid': m, 'duration': d, 'shape': 'raised cosine' if sh else 'linear', 'unit': 's'}
            for m, d, sh in pb.durations
        ],
        'blocks': blocks,
    }


def describe_unexplained(
    problem: Problem, sim: SimulatedRecord, *, sigma: float | None = None
) -> list[Unexplained]:
    """Describe residual structure beyond white noise in the torsion-moment residual.

    A finding is reported when it is large against the noise: a spectral line
    whose rms exceeds sigma/2 with a PSD prominence >= 30; a motion phase
    whose rms exceeds both 1.5*sigma and 1.5 x the other phases'; a trend
    whose change over the record exceeds sigma with |t| > 5 on block means; a
    time block whose excess rms exceeds sigma and whose rms is more than twice the
    quietest block's;
    a shaft-angle harmonic whose amplitude exceeds sigma/2 (only when the
    record covers at least two shaft revolutions, else it would be a trend).

    Parameters
    ----------
    problem : Problem
        The record's fit problem.
    sim : SimulatedRecord
        The model's simulation whose residual is described.
    sigma : float or None
        The noise floor [N m] (None: estimated from the residual).

    Returns
    -------
    list[Unexplained]
        The findings, each with where and how large.
    """
    rec = problem.record
    cov = sim.covered
    r = torque_residual(problem, sim)
    rc, tc = r[cov], rec.time[cov]
    s = noise_floor(rc) if sigma is None else sigma
    total = rms(rc)
    out: list[Unexplained] = []
    # spectral lines (frequency relative to the stick-slip frequency helps the reader)
    stick = np.nan_to_num(sim.stick, nan=1.0) > 0.5
    n_breaks = int(np.count_nonzero(np.diff(stick.astype(np.int8)) == -1))
    duration = float(tc[-1] - tc[0]) if tc.size > 1 else 0.0
    f_ss = n_breaks / duration if duration > 0 else float('nan')
    for ln in spectral_lines(tc, rc, rec.fs, max_lines=5, min_prominence=30.0):
        if ln.amplitude / math.sqrt(2.0) < 0.5 * s:
            continue
        ratio = ln.frequency / f_ss if f_ss and math.isfinite(f_ss) and f_ss > 0 else math.nan
        harmonic = math.isfinite(ratio) and abs(ratio - round(ratio)) < 0.03 and round(ratio) >= 1
        where = (
            f'harmonic {round(ratio)} of the stick-slip frequency {f_ss:.2f} Hz'
            if harmonic
            else f'not a harmonic of the stick-slip frequency ({f_ss:.2f} Hz)'
        )
        out.append(
            Unexplained(
                'spectral_line',
                where,
                ln.amplitude,
                ln.frequency,
                {'prominence': ln.prominence, 'stick_slip_frequency': f_ss},
            )
        )
    # phase concentration
    labels = phase_labels(np.nan_to_num(sim.slip_speed), stick)
    pr = {name: rms(r[cov & (labels == code)]) for code, name in enumerate(PHASE_NAMES)}
    for name, v in pr.items():
        others = [w for k, w in pr.items() if k != name and math.isfinite(w)]
        if (
            math.isfinite(v)
            and others
            and v > 1.5 * s
            and v > 1.5 * max(others)
            and math.sqrt(max(v * v - s * s, 0.0)) > s
        ):
            out.append(
                Unexplained(
                    'phase',
                    f'residual concentrated in the {name.replace("_", " ")} phase',
                    math.sqrt(max(v * v - s * s, 0.0)),
                    None,
                    {f'rms_{k}': w for k, w in pr.items()},
                )
            )
    # trend with test time
    tr = trend(tc, rc)
    if abs(tr.change) > s and abs(tr.t_stat) > 5.0:
        out.append(
            Unexplained(
                'trend',
                'residual drifts with test time',
                abs(tr.change),
                None,
                {'slope': tr.slope, 't_stat': tr.t_stat},
            )
        )
    # concentration in test time (a mismatch that grows or changes over the record)
    seg = problem.segments
    blocks = []
    for b in range(seg.n_blocks):
        m = seg.sample_mask(rec.time.size, seg.block == b) & cov
        if np.count_nonzero(m) > 10:
            blocks.append((rms(r[m]), float(rec.time[m][0]), float(rec.time[m][-1])))
    if len(blocks) >= 3:
        hi = max(blocks)
        lo = min(blocks)
        excess_hi = math.sqrt(max(hi[0] ** 2 - s * s, 0.0))
        if excess_hi > s and hi[0] > 2.0 * lo[0]:
            out.append(
                Unexplained(
                    'time',
                    f'residual largest at t = {hi[1]:.2f}-{hi[2]:.2f} s (rms {hi[0]:.3g} N m), '
                    f'smallest at t = {lo[1]:.2f}-{lo[2]:.2f} s ({lo[0]:.3g} N m)',
                    excess_hi,
                    None,
                    {'t_start': hi[1], 't_end': hi[2], 'rms_min': lo[0], 'rms_max': hi[0]},
                )
            )
    # shaft angle (only with >= 2 revolutions)
    revs = float(np.sum(rec.speed) * rec.dt) / (2 * math.pi)
    if revs >= 2.0:
        ang = angle_dependence(shaft_angle(problem)[cov], rc)
        if ang.amplitude > 0.5 * s:
            out.append(
                Unexplained(
                    'shaft_angle',
                    f'residual varies with the shaft angle (order {ang.order})',
                    ang.amplitude,
                    None,
                    {'order': float(ang.order), 'phase': ang.phase},
                )
            )
    excess = math.sqrt(max(total * total - s * s, 0.0))
    if not out and excess > 1.5 * s:
        out.append(
            Unexplained(
                'broadband',
                'residual above the noise floor without a clear pattern',
                excess,
                None,
                {'rms': total, 'noise_floor': s},
            )
        )
    return out


def propose_terms(
    problem: Problem, sim: SimulatedRecord, unexplained: Sequence[Unexplained], sigma: float
) -> tuple[SparseTerm, ...]:
    """Propose data-driven terms: sparse regression (STLSQ) of the torque residual.

    Parameters
    ----------
    problem : Problem
        The record's fit problem.
    sim : SimulatedRecord
        The final model's simulation.
    unexplained : Sequence[Unexplained]
        The findings (their spectral lines join the term library).
    sigma : float
        The noise floor [N m]; terms below half of it are dropped.

    Returns
    -------
    tuple[SparseTerm, ...]
        The selected terms.
    """
    cov = sim.covered
    rec = problem.record
    lines = tuple(u.frequency for u in unexplained if u.frequency is not None)
    lib = feature_library(
        time=rec.time[cov],
        slip_speed=np.nan_to_num(sim.slip_speed)[cov],
        stick=np.nan_to_num(sim.stick)[cov],
        shaft_angle=shaft_angle(problem)[cov],
        chamber_speed=np.nan_to_num(sim.chamber_speed)[cov],
        line_frequencies=lines,
        include_angle=float(np.sum(rec.speed) * rec.dt) >= 4 * math.pi,
    )
    r = torque_residual(problem, sim)[cov]
    model = stlsq(lib, r, threshold=0.5 * sigma)
    return model.terms


__all__ = ['Unexplained', 'block_speeds', 'describe_unexplained', 'drive_report', 'propose_terms']
