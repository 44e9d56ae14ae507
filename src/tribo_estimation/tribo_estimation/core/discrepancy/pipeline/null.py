"""What "nothing missing" looks like for this record: adequacy statistics and their null law.

A model is *adequate* when its residual looks like the record's noise. Per fit,
:func:`adequacy` gives dimensionless statistics (each large when the model misses
something):

- ``torsion_moment``, ``speed``: the rms of the channel's residual over the
  simulated samples divided by the channel's measured white noise
  (:func:`.noise.measure_noise`) [-];
- ``blocks``: the largest rms of the torsion-moment residual in a time block over
  the median block's [-] (a mismatch that changes during the record).

Their distribution under "nothing missing" is measured on this record by a
parametric bootstrap (:func:`null_law`): the fitted model is simulated as one
stretch from the record's first segment state (:meth:`..fitting.Problem.simulate`
with ``continuous``) through the identified drive profile and speed sensor, the
measured white noise (:class:`.noise.NoiseModel`) is added, and each
replica is prepared and refitted like the record itself. Thresholds are the
one-sided prediction bounds of the replicas' log statistics (normal law, Student
t with B - 1 degrees of freedom, ``sqrt(1 + 1/B)``), at ``alpha`` shared equally
among the statistics (Bonferroni): the chance that an adequate model fails any
of them is at most ``alpha``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from tribo_estimation.errors import EstimationError

from ..candidates import ParamSpec
from ..fitting import Problem, Record, SimulatedRecord
from .noise import RAW_CHANNELS, NoiseModel, measure_noise
from .prepare import channel_floors

FloatArray = np.ndarray

#: The adequacy statistics, in report order. The acceleration's residual is reported,
#: not judged: it is dominated by the jumps of the sampled acceleration at the switching
#: events, whose sub-sample timing a rig's accelerometer and the model sample differently,
#: so its null law is not one the replicas reproduce.
STATISTICS: tuple[str, ...] = ('torsion_moment', 'speed', 'blocks')


#: Largest torsion-moment centre of a usable null law [-]: sqrt(2), where the
#: workflow's own error on its replicas equals their noise (:meth:`NullLaw.self_consistent`).
SELF_ERROR_LIMIT = math.sqrt(2.0)


@dataclass(frozen=True)
class Adequacy:
    """Adequacy statistics of one fit (see the module docstring) [-].

    Parameters
    ----------
    values : dict of str to float
        Statistic name -> value [-].
    noise : NoiseModel
        The noise measured on this fit.
    """

    values: dict[str, float]
    noise: NoiseModel

    def __getitem__(self, name: str) -> float:
        """Return one statistic [-]."""
        return self.values[name]


def raw_residuals(problem: Problem, sim: SimulatedRecord) -> dict[str, FloatArray]:
    """Return measured minus simulated per raw channel (NaN off the simulated samples).

    The channel's mains lines (:attr:`..fitting.Problem.hum_lines`) are projected out.

    Parameters
    ----------
    problem : Problem
        The record's fit problem.
    sim : SimulatedRecord
        The model output.

    Returns
    -------
    dict of str to numpy.ndarray
        Per :data:`.noise.RAW_CHANNELS` [unit].
    """
    rec = problem.record
    cov = sim.covered
    out = {}
    for c in RAW_CHANNELS:
        r = np.asarray(rec.channel(c) - sim.channel(c), dtype=np.float64)
        r[cov] = problem.without_lines(c, r[cov], cov)
        out[c] = r
    return out


def _rms(x: FloatArray) -> float:
    x = x[np.isfinite(x)]
    return float(np.sqrt(np.mean(x * x))) if x.size else math.nan


def adequacy(problem: Problem, sim: SimulatedRecord) -> Adequacy:
    """Return the adequacy statistics of a model's simulation.

    Parameters
    ----------
    problem : Problem
        The record's fit problem.
    sim : SimulatedRecord
        The model's simulation.

    Returns
    -------
    Adequacy
        The statistics and the noise measured on them.
    """
    res = raw_residuals(problem, sim)
    cov = sim.covered
    noise = measure_noise(res, cov)
    vals: dict[str, float] = {}
    for c in (*RAW_CHANNELS,):
        tot = noise.channel(c).total
        vals[c] = _rms(res[c][cov]) / tot if tot > 0 else math.inf
    seg = problem.segments
    n = problem.record.time.size
    block_rms = []
    for b in range(seg.n_blocks):
        m = seg.sample_mask(n, seg.block == b) & cov
        if np.count_nonzero(m) > 10:
            block_rms.append(_rms(res['torsion_moment'][m]))
    vals['blocks'] = max(block_rms) / float(np.median(block_rms)) if len(block_rms) >= 3 else 1.0
    return Adequacy(vals, noise)


def replica(
    problem: Problem, values: Mapping[str, float], noise: NoiseModel, rng: np.random.Generator
) -> Record:
    """Return a record of the model ``values`` with the record's measured noise.

    Parameters
    ----------
    problem : Problem
        The record's fit problem (drive profile, speed sensor, first segment state).
    values : mapping of str to float
        The model's values.
    noise : NoiseModel
        The noise to add.
    rng : numpy.random.Generator
        Random source.

    Returns
    -------
    Record
        The replica, from the first segment's start (from the record's first sample
        when it begins at the drive's start and that segment in its initial stick) to
        the record's end.
    """
    sim = problem.simulate(values, continuous=True)
    i0 = int(np.flatnonzero(sim.covered)[0])
    rec = problem.record
    # a record that begins at the drive's start with its first segment in the initial
    # stick from rest: so does its replica, the samples before that segment holding the
    # model's state there (the discs stuck, at rest), so that its profile starts from
    # rest at the drive's start and its initial stick starts a segment, as the record's
    first = 0 if problem.begins_at_drive_start and sim.stick[i0] > 0.5 else i0
    n = rec.time.size - first
    chans = {
        c: np.concatenate([np.full(i0 - first, sim.channel(c)[i0]), sim.channel(c)[i0:]])
        + noise.channel(c).draw(rng, n, rec.dt)
        for c in RAW_CHANNELS
    }
    return Record(
        rec.time[first:].copy(),
        chans['torsion_moment'],
        chans['angular_acceleration'],
        chans['speed'],
    )


@dataclass(frozen=True)
class NullLaw:
    """The adequacy statistics' distribution under "nothing missing" (module docstring).

    Parameters
    ----------
    samples : dict of str to tuple of float
        Statistic name -> its value on every replica [-].
    alpha : float
        Chance that an adequate model fails any statistic [-].
    drifts : tuple of float
        The stick kinematics' drift (:attr:`..fitting.SpeedSensor.drift`) of every
        replica [-].
    """

    samples: dict[str, tuple[float, ...]]
    alpha: float
    drifts: tuple[float, ...] = ()

    @property
    def replicas(self) -> int:
        """Number of replicas."""
        return min((len(v) for v in self.samples.values()), default=0)

    def bound(self, name: str) -> float:
        """Return the threshold of one statistic [-] (NaN without two replicas: no law).

        Parameters
        ----------
        name : str
            One of :data:`STATISTICS`.

        Returns
        -------
        float
            The one-sided prediction bound at ``alpha / len(samples)``.
        """
        x = np.log(np.asarray([v for v in self.samples[name] if v > 0 and math.isfinite(v)]))
        b = x.size
        if b < 2:
            return math.nan
        from scipy.stats import t as student_t

        q = float(student_t.ppf(1.0 - self.alpha / max(len(self.samples), 1), b - 1))
        return math.exp(float(np.mean(x)) + q * float(np.std(x, ddof=1)) * math.sqrt(1.0 + 1.0 / b))

    def tolerance(self, name: str) -> float:
        """Return the log excess over the centre that the null law allows [-].

        Two fits of one record whose statistics differ by less than this cannot be
        told apart by the record (the difference is within what noise gives).
        """
        b = self.bound(name)
        c = self.centre(name)
        return math.log(b / c) if math.isfinite(b) and c > 0 else math.inf

    def drift_outlier(self, drift: float) -> bool:
        """Tell whether the record's stick-kinematics drift lies outside its null law.

        Two-sided prediction bound of the replicas' drifts (no Bonferroni share: one
        statistic, its own gate at ``alpha``); False without the drift's replicas.

        Parameters
        ----------
        drift : float
            The record's drift [-] (:attr:`..fitting.SpeedSensor.drift`).

        Returns
        -------
        bool
            True when the rig or an instrument changes during the record.
        """
        x = np.asarray([v for v in self.drifts if math.isfinite(v)])
        if x.size < 2 or not math.isfinite(drift):
            return False
        from scipy.stats import t as student_t

        q = float(student_t.ppf(1.0 - self.alpha / 2.0, x.size - 1))
        half = q * float(np.std(x, ddof=1)) * math.sqrt(1.0 + 1.0 / x.size)
        return abs(drift - float(np.mean(x))) > half

    def self_consistent(self) -> bool:
        """Tell whether the replicas are refitted to within the noise of their own model.

        A replica is the fitted model plus the record's white noise s; refitted, it
        leaves ``sqrt(1 + (e/s)**2)`` of the torsion-moment statistic, where e [N m rms]
        is the workflow's own error on a record of known model (drive profile, segment
        states and instruments identified from noisy data). Beyond
        :data:`SELF_ERROR_LIMIT` that error exceeds the noise, and the law describes the
        fit's failure rather than the noise: no decision may rest on it
        (docs/physics.md, section 8). A law without replicas is not judged here.

        Returns
        -------
        bool
            False when the replicas' torsion-moment centre exceeds the limit.
        """
        c = self.centre('torsion_moment')
        return not c > SELF_ERROR_LIMIT

    def centre(self, name: str) -> float:
        """Return the replicas' geometric mean of one statistic [-]."""
        x = np.log(np.asarray([v for v in self.samples[name] if v > 0 and math.isfinite(v)]))
        return math.exp(float(np.mean(x))) if x.size else math.nan

    def failing(self, stats: Adequacy) -> tuple[str, ...]:
        """Return the statistics of ``stats`` beyond their bound (empty: adequate).

        Parameters
        ----------
        stats : Adequacy
            A fit's statistics.

        Returns
        -------
        tuple of str
            The names of the failing statistics (all of them without a law: a model is
            only adequate against a measured null law).
        """
        return tuple(n for n in self.samples if not stats.values[n] <= self.bound(n))

    def pooled(self, earlier: NullLaw, keep: int) -> NullLaw:
        """Return this law's replicas followed by the newest of ``earlier``, ``keep`` in all.

        For a stream whose windows overlap (the live monitor): the same process, the
        same noise, so the replicas of recent windows are samples of the same law.

        Parameters
        ----------
        earlier : NullLaw
            The law of the earlier windows (its replicas newest first).
        keep : int
            Replicas of the pooled law (at least this law's own).

        Returns
        -------
        NullLaw
            The pooled law, newest replicas first, at this law's ``alpha``.
        """
        n = max(keep - self.replicas, 0)
        return NullLaw(
            {k: (*v, *earlier.samples.get(k, ())[:n]) for k, v in self.samples.items()},
            self.alpha,
            (*self.drifts, *earlier.drifts[:n]),
        )

    def as_dict(self) -> dict[str, object]:
        """Return the JSON-ready form (per statistic: replicas' centre and bound)."""
        return {
            'alpha': self.alpha,
            'replicas': self.replicas,
            **{n: {'centre': self.centre(n), 'bound': self.bound(n)} for n in self.samples},
        }


def null_law(
    problem: Problem,
    values: Mapping[str, float],
    free: Sequence[ParamSpec],
    noise: NoiseModel,
    *,
    replicas: int,
    alpha: float,
    seed: int,
    max_nfev: int,
) -> NullLaw:
    """Measure the adequacy statistics' null law by a parametric bootstrap.

    Each replica (:func:`replica`) is refitted by the record's estimator: the
    record's problem settings, its open transitions timed, the channel weights from
    the replica's residuals at ``values`` (as the baseline's are from the record's,
    :meth:`..fitting.Problem.set_residual_weights`), the free parameters from
    ``values``; its statistics, like the record's, from the segments' corrected starts
    (:meth:`..fitting.Problem.refined`).

    Parameters
    ----------
    problem : Problem
        The record's fit problem.
    values : mapping of str to float
        The fitted model (the truth of the replicas).
    free : sequence of ParamSpec
        The model's fitted parameters (refitted on every replica).
    noise : NoiseModel
        The record's measured noise.
    replicas : int
        Number of replicas.
    alpha : float
        False-alarm rate of the adequacy decision [-].
    seed : int
        Seed of the replicas' noise.
    max_nfev : int
        Simulations per replica's refit.

    Returns
    -------
    NullLaw
        The replicas' statistics.
    """
    from ..fitting import identify_speed_sensor

    rng = np.random.default_rng(seed)
    out: dict[str, list[float]] = {n: [] for n in STATISTICS}
    drifts: list[float] = []
    for _ in range(replicas):
        try:
            rep = problem.like(replica(problem, values, noise, rng))
            rep.set_transition_durations(values)  # the record's estimator: open steps timed
            # the record's estimator: channel weights from the residuals at the model (the
            # record's own weights carry its misfit: a torque residual of 18x its noise
            # weighed the replica's torque 35x below its noise, and the refit traded it for
            # the speed channel)
            sim = rep.simulate(values)
            rep.set_residual_weights(sim, channel_floors(rep, sim))
            fo = rep.fit(free, values, max_nfev=max_nfev)
            st = adequacy(rep, rep.refined(fo.values))
        except EstimationError:  # a replica that cannot be fitted gives no sample
            continue
        for n in STATISTICS:
            out[n].append(st.values[n])
        drifts.append(identify_speed_sensor(rep.record, rep.rig, rep.segments.stick_phases()).drift)
    return NullLaw({n: tuple(v) for n, v in out.items()}, alpha, tuple(drifts))


__all__ = [
    'SELF_ERROR_LIMIT',
    'STATISTICS',
    'Adequacy',
    'NullLaw',
    'adequacy',
    'null_law',
    'raw_residuals',
    'replica',
]
