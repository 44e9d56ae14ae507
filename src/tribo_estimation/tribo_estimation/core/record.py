"""The rig record: the four measured channels on one regular time base (no rclpy).

:class:`RigRecord` is the one shape of a stick-slip record in the package: what
:func:`tribo_estimation.core.inputs.read_record` returns after the input checks,
what the simulator returns (:class:`~tribo_estimation.core.simulate.SimResult`
adds the truth), what the discrepancy workflow fits and what the live model
monitor evaluates. Channels (paper symbols, SI units):

* ``time`` [s] on the drive's time base: sample ``i`` of the stream at ``i / fs``
  (a record read from a file starts at its first sample's index over ``fs``);
* ``torsion_moment`` ``C1 phi1`` [N m];
* ``angular_acceleration`` of the chamber ``w1'`` [rad/s^2];
* ``speed`` of the shaft ``w2`` [rad/s].

:class:`InputFindings` holds what the input checks found and did (replaced
spike and burst samples, warnings, stamp jitter, gaps, a bag that ends early).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from tribo_estimation.errors import InvalidDataError

if TYPE_CHECKING:
    import pandas as pd

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

#: The four measured channels of a record, in file order.
CHANNELS: tuple[str, str, str, str] = ('time', 'torsion_moment', 'angular_acceleration', 'speed')
#: Unit of each channel.
CHANNEL_UNITS: dict[str, str] = {
    'time': 's',
    'torsion_moment': 'N m',
    'angular_acceleration': 'rad/s^2',
    'speed': 'rad/s',
}
#: Largest deviation of a time step from the mean step [-] (a record is uniformly sampled).
UNIFORM_TOL = 0.01
#: Shortest run of replaced samples counted as a burst [samples].
BURST_RUN = 3


def _no_samples() -> BoolArray:
    return np.zeros(0, dtype=bool)


@dataclass(frozen=True, eq=False)
class InputFindings:
    """What the input checks found in a record and did to it.

    Attributes
    ----------
    replaced : numpy.ndarray of bool
        True at the samples replaced by interpolation (spikes, bursts, values
        beyond any physical bound), one entry per sample of the record; empty:
        none replaced. The block fit leaves these samples out of its residuals.
    warnings : tuple of str
        Warnings of the checks (each names the channel and the value).
    max_jitter : float
        Largest distance of a written time stamp from the regular grid
        [sample intervals]; jittered stamps are resampled onto the grid.
    stretches : int
        Gap-free stretches in the read window (the record is the longest).
    truncated : str
        The error of a bag that ends early ('' if none): the record is the good
        part before the damage.
    """

    replaced: BoolArray = field(default_factory=_no_samples)
    warnings: tuple[str, ...] = ()
    max_jitter: float = 0.0
    stretches: int = 1
    truncated: str = ''

    def _runs(self) -> npt.NDArray[np.int64]:
        """Return the lengths of the runs of replaced samples [samples]."""
        if not self.replaced.any():
            return np.zeros(0, dtype=np.int64)
        edges = np.diff(np.concatenate(([0], self.replaced.astype(np.int8), [0])))
        return np.flatnonzero(edges == -1) - np.flatnonzero(edges == 1)

    @property
    def spikes(self) -> int:
        """Return the number of replaced samples [-]."""
        return int(np.count_nonzero(self.replaced))

    @property
    def bursts(self) -> int:
        """Return the number of runs of at least :data:`BURST_RUN` replaced samples [-]."""
        return int(np.count_nonzero(self._runs() >= BURST_RUN))

    @property
    def quality(self) -> str:
        """Return ``ok`` or the flags ``spikes``/``bursts`` (``;``-joined) as in ``blocks.csv``."""
        runs = self._runs()
        flags = [
            f
            for f, on in (('spikes', bool(np.any(runs < BURST_RUN))), ('bursts', self.bursts > 0))
            if on
        ]
        return ';'.join(flags) or 'ok'

    def summary(self) -> dict[str, int | str]:
        """Return the counts of the repair for a results file.

        Returns
        -------
        dict
            ``spikes``: replaced samples [-], ``bursts``: runs of three or more
            of them [-], ``quality``: ``ok`` or the flags.
        """
        return {'spikes': self.spikes, 'bursts': self.bursts, 'quality': self.quality}


@dataclass(frozen=True, eq=False)
class RigRecord:
    """A stick-slip record on a uniform time base (see the module docstring).

    Parameters
    ----------
    time : numpy.ndarray
        Sample times [s], strictly increasing, uniform within :data:`UNIFORM_TOL`.
    torsion_moment : numpy.ndarray
        Torsion moment ``C1 phi1`` [N m].
    angular_acceleration : numpy.ndarray
        Chamber acceleration ``w1'`` [rad/s^2].
    speed : numpy.ndarray
        Shaft speed ``w2`` [rad/s].
    fs : float
        Sample rate [Hz]; NaN (default): from ``time``.
    findings : InputFindings
        What the input checks found (default: no check ran, nothing replaced).
    source : str
        Where the samples come from (a file, a bag and namespace, ``simulation``).
    time_origin : float
        Time stamp of ``time == 0`` as written in the source (epoch or file time)
        [s]: sample ``i`` was stamped ``time_origin + time[i]``.

    Raises
    ------
    InvalidDataError
        Columns of different lengths or not 1-D, a non-finite value, a time
        base that is not strictly increasing and uniform, no samples, or no
        usable sample rate.
    """

    time: FloatArray
    torsion_moment: FloatArray
    angular_acceleration: FloatArray
    speed: FloatArray
    fs: float = math.nan
    findings: InputFindings = field(default_factory=InputFindings)
    source: str = '<record>'
    time_origin: float = 0.0

    def __post_init__(self) -> None:
        """Check the columns and the time base; derive ``fs`` when not given."""
        n = -1
        for name in CHANNELS:
            a = np.ascontiguousarray(getattr(self, name), dtype=np.float64)
            object.__setattr__(self, name, a)
            if a.ndim != 1 or (n >= 0 and a.size != n):
                raise InvalidDataError(
                    f'{self.source}: record column {name!r} has shape {a.shape}, '
                    f'expected ({max(n, 0)},)'
                )
            n = a.size
            bad = np.flatnonzero(~np.isfinite(a))
            if bad.size:
                raise InvalidDataError(
                    f'{self.source}: record column {name!r} has a non-finite value at '
                    f'sample {int(bad[0])}'
                )
        if n == 0:
            raise InvalidDataError(f'{self.source}: record has no samples')
        t = self.time
        fs = float(self.fs)
        if n > 1:
            dt = np.diff(t)
            if np.any(dt <= 0):
                i = int(np.flatnonzero(dt <= 0)[0]) + 1
                raise InvalidDataError(
                    f'{self.source}: record time is not strictly increasing at sample {i}'
                )
            mean = float((t[-1] - t[0]) / (n - 1))
            dev = np.abs(dt - mean)
            if n > 2 and float(dev.max()) > UNIFORM_TOL * mean:
                i = int(np.argmax(dev)) + 1
                raise InvalidDataError(
                    f'{self.source}: record is not uniformly sampled (step {dt[i - 1]:.3g} s at '
                    f'sample {i}, mean {mean:.3g} s); resample it first'
                )
            if math.isnan(fs):
                fs = 1.0 / mean
        if not (math.isfinite(fs) and fs > 0.0):
            raise InvalidDataError(f'{self.source}: record has no usable sample rate ({fs} Hz)')
        object.__setattr__(self, 'fs', fs)
        rep = self.findings.replaced
        if rep.size not in (0, n):
            raise InvalidDataError(
                f'{self.source}: findings mark {rep.size} samples, the record has {n}'
            )

    def __len__(self) -> int:
        """Return the number of samples."""
        return int(self.time.size)

    @property
    def dt(self) -> float:
        """Sample interval [s]."""
        return 1.0 / self.fs

    @property
    def duration(self) -> float:
        """Time the record spans, ``len / fs`` [s]."""
        return len(self) / self.fs

    @property
    def first_index(self) -> int:
        """Sample counter of the first sample on the drive's time base [-]."""
        return round(float(self.time[0]) * self.fs)

    @property
    def replaced(self) -> BoolArray:
        """Return True at the replaced samples (one entry per sample)."""
        rep = self.findings.replaced
        return rep if rep.size else np.zeros(len(self), dtype=bool)

    def channel(self, name: str) -> FloatArray:
        """Return a measured column by name.

        Parameters
        ----------
        name : str
            Field name of the column (e.g. ``'torsion_moment'``).

        Returns
        -------
        numpy.ndarray
            The column in its unit (:data:`CHANNEL_UNITS`).
        """
        return np.asarray(getattr(self, name), dtype=np.float64)

    def columns(self) -> dict[str, FloatArray]:
        """Return the record's columns by name (the channels, then ``replaced``).

        Returns
        -------
        dict of str to numpy.ndarray
            :data:`CHANNELS` in their units, ``replaced`` (1.0 at replaced samples).
        """
        cols = {name: self.channel(name) for name in CHANNELS}
        cols['replaced'] = self.replaced.astype(np.float64)
        return cols

    def rows(self) -> list[dict[str, float]]:
        """Return one plain dict per sample (:meth:`columns`).

        Returns
        -------
        list of dict
            Column name -> value.
        """
        cols = self.columns()
        names = list(cols)
        return [dict(zip(names, vals, strict=True)) for vals in zip(*cols.values(), strict=True)]

    def to_frame(self) -> pd.DataFrame:
        """Return :meth:`columns` as a pandas DataFrame (pandas is imported then).

        Returns
        -------
        pandas.DataFrame
            One row per sample.
        """
        import pandas as pd

        return pd.DataFrame(self.columns())

    def write(self, path: str | os.PathLike[str]) -> Path:
        """Write the record as a rig CSV file (``docs/ARCHITECTURE.md``, "Rig CSV").

        The time column is :attr:`time` (the drive's time base); the source and
        :attr:`time_origin` go into ``# key: value`` comments.

        Parameters
        ----------
        path : str or PathLike
            The CSV file.

        Returns
        -------
        Path
            ``path``.
        """
        from tribo_estimation.core.rigio import write_rig_csv

        write_rig_csv(
            Path(path),
            self.time,
            self.torsion_moment,
            self.angular_acceleration,
            self.speed,
            extra=self.extra_columns(),
            metadata={'source': self.source, 'time_origin_s': repr(self.time_origin)},
        )
        return Path(path)

    def extra_columns(self) -> dict[str, FloatArray]:
        """Return the columns a rig CSV carries after the four channels (none).

        Returns
        -------
        dict of str to numpy.ndarray
            Empty for a measured record.
        """
        return {}

    def plot(self, path: str | os.PathLike[str], title: str = '') -> Path:
        """Draw the record's channels over time into a PNG file.

        Parameters
        ----------
        path : str or PathLike
            The PNG file.
        title : str
            Figure title (default: the source).

        Returns
        -------
        Path
            ``path``.
        """
        from tribo_estimation.plots import plot_record

        plot_record(self, path, title=title or self.source)
        return Path(path)

    def window(self, start: float = 0.0, duration: float = 0.0) -> RigRecord:
        """Return the samples from ``start`` after the first sample for ``duration``.

        Parameters
        ----------
        start : float
            Offset from the first sample [s] (>= 0).
        duration : float
            Length [s]; 0: to the end.

        Returns
        -------
        RigRecord
            The window (same rate, source and findings of its samples).

        Raises
        ------
        InvalidDataError
            A negative or non-finite start or duration, or a window without samples.
        """
        if not (math.isfinite(start) and start >= 0.0):
            raise InvalidDataError(f'{self.source}: window start must be >= 0 s, got {start}')
        if not (math.isfinite(duration) and duration >= 0.0):
            raise InvalidDataError(f'{self.source}: window duration must be >= 0 s, got {duration}')
        i0 = round(start * self.fs)
        i1 = len(self) if duration == 0.0 else min(len(self), i0 + round(duration * self.fs))
        if i1 - i0 < 1:
            raise InvalidDataError(
                f'{self.source}: the window start {start:g} s, duration {duration:g} s holds '
                'no sample'
            )
        rep = self.findings.replaced
        findings = InputFindings(
            rep[i0:i1] if rep.size else rep,
            self.findings.warnings,
            self.findings.max_jitter,
            self.findings.stretches,
            self.findings.truncated,
        )
        return RigRecord(
            self.time[i0:i1],
            self.torsion_moment[i0:i1],
            self.angular_acceleration[i0:i1],
            self.speed[i0:i1],
            self.fs,
            findings,
            self.source,
            self.time_origin,
        )
