"""Value types of the discrepancy fit: the measured record, its segments, the model output.

Also the compared channels and the parameter specifications fitted with every
model (the friction levels of Equ. 8 and the speed sensor's instrument model).
Units: SI (s, N m, rad/s, rad/s^2).
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np
import numpy.typing as npt

from tribo_estimation.core.model import Extensions
from tribo_estimation.core.record import RigRecord

from ..candidates import ParamSpec
from ..stats import FloatArray, IntArray

#: Compared channels: the torsion moment (N m), the chamber speed w1 (rad/s;
#: measured = the angular acceleration integrated from each segment start,
#: simulated = the state; a smooth function of the parameters, unlike the
#: sampled acceleration, which jumps at every breakaway) and the shaft speed (rad/s).
CHANNELS: tuple[str, str, str] = ('torsion_moment', 'chamber_speed', 'speed')
CHANNEL_UNITS: dict[str, str] = {
    'torsion_moment': 'N m',
    'chamber_speed': 'rad/s',
    'speed': 'rad/s',
}

#: Extensions fields that act on the measurement, not on the dynamics.
MEASUREMENT_FIELDS: frozenset[str] = frozenset(
    {
        'torque_offset',
        'torque_offset_drift',
        'torque_lag_tau',
        'torque_thermal',
        'torque_thermal_tau',
    }
)
#: Every field name of :class:`~tribo_estimation.core.model.Extensions`.
EXT_FIELDS: frozenset[str] = frozenset(f.name for f in fields(Extensions))

#: Friction parameters of the baseline (Equ. 8), fitted in every model.
MU0 = ParamSpec('mu0', '-', 0.0, 2.0, 0.01, 0.1)
MU_INF = ParamSpec('mu_inf', '-', 0.0, 2.0, 0.01, 0.1)
#: The decay constant k of Equ. 8 [s/rad], fitted with the levels (RIG.yaml's value is
#: the start: a preset such as the paper's 2 s/rad is rarely the contact's).
K_DECAY = ParamSpec('k', 's/rad', 0.05, 100.0, 1.0, 2.0, log=True)

#: Instrument model of the shaft-speed channel, fitted with the baseline:
#: first-order sensor lag [s] and zero offset [rad/s]. The simulated shaft speed
#: passes through them before it is compared; the state at segment starts does
#: not use the speed channel (the common speed comes from dM_t/dt), so the
#: other channels are insensitive to both.
SPEED_LAG = ParamSpec('speed_lag_tau', 's', 0.0, 0.02, 1e-3, 0.0)
SPEED_OFFSET = ParamSpec('speed_offset', 'rad/s', -1.0, 1.0, 0.01, 0.0)
#: The speed sensor's second order: ``a2*y'' + tau*y' + y = w`` with
#: ``a2 = speed_lag_shape*tau^2`` (0: first order; 1/(4 zeta^2) for a damping ratio
#: zeta). Bounded at 2, a damping ratio of 0.35: a tachometer filter ringing more
#: than that overshoots a step by over 30 % (docs/physics.md).
SPEED_SHAPE = ParamSpec('speed_lag_shape', '-', 0.0, 2.0, 0.1, 0.0)
INSTRUMENT: tuple[ParamSpec, ...] = (SPEED_LAG, SPEED_OFFSET, SPEED_SHAPE)
INSTRUMENT_FIELDS: frozenset[str] = frozenset(p.name for p in INSTRUMENT)

#: The shaft side of the rig (Equ. 2: I2, K2, C2) as factors on RIG.yaml's design
#: values, identified with the baseline: inertia and stiffness within 0.6-1.6 of the
#: design value, the belt damping (the least known) within 0.4-2.5 (docs/physics.md).
SHAFT_I2 = ParamSpec('shaft_I2', '-', 0.6, 1.6, 0.1, 1.0)
SHAFT_K2 = ParamSpec('shaft_K2', '-', 0.4, 2.5, 0.1, 1.0)
SHAFT_C2 = ParamSpec('shaft_C2', '-', 0.6, 1.6, 0.1, 1.0)
SHAFT: tuple[ParamSpec, ...] = (SHAFT_I2, SHAFT_K2, SHAFT_C2)
SHAFT_FIELDS: frozenset[str] = frozenset(p.name for p in SHAFT)
#: The chamber's inertia I1 (Equ. 1) as a factor on RIG.yaml's, fitted with the
#: baseline of every record: the chamber's lightly damped mode sqrt(C1/I1) runs through
#: each slip phase and a whole sliding segment, so the ~1 % a free-decay identification
#: leaves on C1 and I1 shows as a phase error over ten cycles. The torsion moment is the
#: measured M_t = C1*phi1 and the accelerometer's gain is referred to C1
#: (:func:`.instrument.identify_accel_sensor`), so the factor carries the error of the
#: ratio C1/I1 in RIG.yaml's C1. Within 0.9-1.1: a free-decay identification's error
#: (docs/physics.md).
CHAMBER_I1 = ParamSpec('chamber_I1', '-', 0.9, 1.1, 0.01, 1.0)
#: Factors on RIG.yaml's rig parameters, by value name: the rig field each scales.
RIG_FACTORS: dict[str, str] = {
    'shaft_I2': 'I2',
    'shaft_K2': 'K2',
    'shaft_C2': 'C2',
    'chamber_I1': 'I1',
}
RIG_FACTOR_FIELDS: frozenset[str] = frozenset(RIG_FACTORS)


#: The measured record: the package's one record type
#: (:class:`~tribo_estimation.core.record.RigRecord`).
Record = RigRecord


@dataclass(frozen=True)
class Segments:
    """Simulation segments of a record (the multiple-shooting intervals).

    Parameters
    ----------
    start, stop : IntArray
        First and stop (exclusive) sample index of each segment.
    stick_time : FloatArray
        Time already spent sticking at each segment start [s].
    block : IntArray
        Time block of each segment (the unit of cross validation).
    run_start, run_stop : IntArray or None
        First and stop sample of the stick phase holding each start.
    sliding : bool
        True: the record has no stick-slip; every segment starts while sliding.
    rejected : tuple of (float, str)
        Detected stick phases not used as segment starts: start time [s] and
        reason (their samples stay in the fit, inside the segment before).
    unknown_dwell : tuple of (int, int)
        First and stop sample of the stick phases that start no segment because
        their dwell is unknown (cut by the record start, or begun well before the
        detected onset): the discs stick there all the same, so they inform the
        instrument model and the drive profile (:meth:`stick_phases`).
    slides : numpy.ndarray of bool or None
        Per segment, True where it starts while sliding (a stretch without stick
        phases in a record with stick-slip; its run is empty); None: all as
        ``sliding`` says.
    """

    start: IntArray
    stop: IntArray
    stick_time: FloatArray
    block: IntArray
    run_start: IntArray | None = None
    run_stop: IntArray | None = None
    sliding: bool = False
    rejected: tuple[tuple[float, str], ...] = ()
    unknown_dwell: tuple[tuple[int, int], ...] = ()
    slides: npt.NDArray[np.bool_] | None = None

    @property
    def sliding_starts(self) -> npt.NDArray[np.bool_]:
        """Per segment, True where it starts while sliding."""
        if self.slides is not None:
            return self.slides
        return np.full(self.n, self.sliding, dtype=bool)

    def stick_phases(self) -> tuple[IntArray, IntArray] | None:
        """Return the stick phases that show the stuck discs, in time order.

        Those holding a segment start and those of unknown dwell; the instrument
        model and the drive profile are fitted on them.

        Returns
        -------
        tuple of (IntArray, IntArray) or None
            First and stop sample of each phase (unique); None without stick phases.
        """
        if self.run_start is None or self.run_stop is None:
            return None
        pairs = {
            (int(a), int(b)) for a, b in zip(self.run_start, self.run_stop, strict=True) if b > a
        }
        pairs |= set(self.unknown_dwell)
        ordered = sorted(pairs)
        return (
            np.asarray([a for a, _ in ordered], dtype=np.int64),
            np.asarray([b for _, b in ordered], dtype=np.int64),
        )

    @property
    def n(self) -> int:
        """Number of segments."""
        return int(self.start.size)

    @property
    def n_blocks(self) -> int:
        """Number of time blocks."""
        return int(self.block.max()) + 1 if self.block.size else 0

    def sample_mask(
        self, n: int, seg_mask: npt.NDArray[np.bool_] | None = None
    ) -> npt.NDArray[np.bool_]:
        """Return the boolean mask of the samples covered by the (selected) segments.

        Parameters
        ----------
        n : int
            Number of samples of the record.
        seg_mask : numpy.ndarray of bool, optional
            Selected segments (default: all).

        Returns
        -------
        numpy.ndarray of bool
            One entry per sample.
        """
        m = np.zeros(n, dtype=bool)
        sel = np.ones(self.n, dtype=bool) if seg_mask is None else seg_mask
        for a, b in zip(self.start[sel], self.stop[sel], strict=True):
            m[a:b] = True
        return m


@dataclass(frozen=True)
class SimulatedRecord:
    """Model output on the record's time base (NaN outside the segments).

    Parameters
    ----------
    torsion_moment : FloatArray
        Torsion moment after the measurement-side extensions [N m].
    angular_acceleration : FloatArray
        Chamber acceleration [rad/s^2].
    speed : FloatArray
        Shaft speed as the speed sensor shows it [rad/s].
    friction_moment : FloatArray
        Friction moment M [N m].
    slip_speed : FloatArray
        Slip speed w2 - w1 [rad/s].
    stick : FloatArray
        1.0 while the discs stick, else 0.0.
    chamber_speed : FloatArray
        Chamber speed w1 [rad/s].
    covered : numpy.ndarray of bool
        The samples inside the simulated segments.
    """

    torsion_moment: FloatArray
    angular_acceleration: FloatArray
    speed: FloatArray
    friction_moment: FloatArray
    slip_speed: FloatArray
    stick: FloatArray
    chamber_speed: FloatArray
    covered: npt.NDArray[np.bool_]

    def channel(self, name: str) -> FloatArray:
        """Return a simulated channel by name.

        Parameters
        ----------
        name : str
            Field name of the channel.

        Returns
        -------
        FloatArray
            The channel in its unit.
        """
        return np.asarray(getattr(self, name), dtype=np.float64)


@dataclass(frozen=True)
class FitOutcome:
    """Result of :meth:`~.problem.Problem.fit`.

    Parameters
    ----------
    values : dict of str to float
        Fitted values of all free and fixed names (their SI units).
    cost : float
        Mean weighted squared residual over the fitted segments [-].
    nfev : int
        Number of function evaluations (simulations).
    converged : bool
        Whether the optimiser converged.
    se : dict of str to float
        Standard errors of the free values (their units).
    """

    values: dict[str, float]
    cost: float
    nfev: int
    converged: bool
    se: dict[str, float] = field(default_factory=dict)
