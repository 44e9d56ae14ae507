"""Rig CSV input/output (contract in docs/ARCHITECTURE.md, "Rig CSV").

Header ``time,torsion_moment,angular_acceleration,speed`` (s, N m, rad/s^2, rad/s);
extra columns after these (the simulator's truth ``friction_moment,slip_speed,stick``)
are kept in :attr:`CsvBlock.extra`. Lines starting with ``#`` are comments;
``# key: value`` comments are returned as metadata. Blank lines are skipped.

Readers check every value: a missing column, a non-numeric or non-finite value,
a time that does not increase, or a speed whose magnitude says rpm instead of
rad/s raise a specific :class:`EstimationError` naming the file, the column and
the line. :func:`iter_rig_csv` reads long files block by block with the same
checks (a one-hour 10 kHz file is never loaded at once). The rows read are raw
stamped samples (:class:`CsvBlock`); :mod:`tribo_estimation.core.inputs` puts them
on the regular time grid (:func:`estimate_rate`, :func:`grid_positions`,
:func:`resample_on_grid`) and through the input checks into a
:class:`~tribo_estimation.core.record.RigRecord`.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import IO

import numpy as np

from tribo_estimation.errors import (
    InvalidDataError,
    IrregularSamplingError,
    MissingColumnError,
    NonMonotonicTimeError,
    TimeBaseError,
    TooShortError,
    UnitError,
)

COLUMNS: tuple[str, ...] = ('time', 'torsion_moment', 'angular_acceleration', 'speed')
UNITS: dict[str, str] = {
    'time': 's',
    'torsion_moment': 'N m',
    'angular_acceleration': 'rad/s^2',
    'speed': 'rad/s',
    'friction_moment': 'N m',
    'slip_speed': 'rad/s',
    'stick': '-',
}
#: Largest plausible shaft speed of the stick-slip rig [rad/s] (955 rpm); a larger
#: magnitude is taken as a speed written in rpm.
MAX_SPEED = 100.0


@dataclass(frozen=True, eq=False)
class CsvBlock:
    """Rows of a rig CSV file as written: stamped samples, not yet checked.

    ``time`` [s] (the stamps as written: epoch or relative, possibly jittered),
    ``torsion_moment`` [N m], ``angular_acceleration`` [rad/s^2], ``speed``
    [rad/s]; ``extra`` further columns by name; ``metadata`` the ``# key: value``
    comments; ``first_line`` the file line of the first sample (1-based).
    """

    time: np.ndarray
    torsion_moment: np.ndarray
    angular_acceleration: np.ndarray
    speed: np.ndarray
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    metadata: dict[str, str] = field(default_factory=dict)
    first_line: int = 0

    def __len__(self) -> int:
        """Return the number of samples."""
        return int(self.time.shape[0])

    @property
    def sample_rate(self) -> float:
        """Mean sample rate [Hz] (NaN for fewer than two samples)."""
        if len(self) < 2:
            return float('nan')
        return float((len(self) - 1) / (self.time[-1] - self.time[0]))


# ----------------------------------------------------------------------------- writing
class RigCsvWriter:
    """Streaming writer: header once, then :meth:`write` block by block."""

    def __init__(
        self,
        path: str | Path,
        extra_columns: tuple[str, ...] = (),
        metadata: Mapping[str, object] | None = None,
    ) -> None:
        self.path = Path(path)
        self.columns = (*COLUMNS, *extra_columns)
        self._fh: IO[str] | None = self.path.open('w', encoding='utf-8', newline='\n')
        units = ', '.join(f'{c} [{UNITS.get(c, "?")}]' for c in self.columns)
        self._fh.write(f'# units: {units}\n')
        for key, val in (metadata or {}).items():
            text = str(val).replace('\n', ' ')
            self._fh.write(f'# {key}: {text}\n')
        self._fh.write(','.join(self.columns) + '\n')
        self.rows = 0

    def write(self, columns: Mapping[str, np.ndarray]) -> None:
        """Append rows; ``columns`` maps every column name to an equal-length array."""
        if self._fh is None:
            raise InvalidDataError(f'{self.path}: writer already closed')
        missing = [c for c in self.columns if c not in columns]
        if missing:
            raise MissingColumnError(f'{self.path}: no data for column(s) {missing}')
        arrs = [np.asarray(columns[c], dtype=float) for c in self.columns]
        n = arrs[0].shape[0]
        if any(a.shape != (n,) for a in arrs):
            raise InvalidDataError(f'{self.path}: columns differ in length')
        fmt = ['%.16g'] + ['%.9g'] * (len(arrs) - 1)  # time: epoch stamps to 1 us
        np.savetxt(self._fh, np.column_stack(arrs), fmt=fmt, delimiter=',')
        self.rows += n

    def close(self) -> None:
        """Flush and close the file (idempotent)."""
        if self._fh is not None:
            self._fh.close()
            self._fh = None

    def __enter__(self) -> RigCsvWriter:
        """Return the writer itself."""
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        """Close the file, also after an exception."""
        self.close()


def write_rig_csv(
    path: str | Path,
    time: np.ndarray,
    torsion_moment: np.ndarray,
    angular_acceleration: np.ndarray,
    speed: np.ndarray,
    *,
    extra: Mapping[str, np.ndarray] | None = None,
    metadata: Mapping[str, object] | None = None,
) -> None:
    """Write one rig CSV file (see the module docstring)."""
    extra = dict(extra or {})
    with RigCsvWriter(path, tuple(extra), metadata) as w:
        w.write(
            {
                'time': time,
                'torsion_moment': torsion_moment,
                'angular_acceleration': angular_acceleration,
                'speed': speed,
                **extra,
            }
        )


# ----------------------------------------------------------------------------- reading
def _parse_header(fh: IO[str], path: Path) -> tuple[list[str], dict[str, str], int]:
    meta: dict[str, str] = {}
    line_no = 0
    for raw in fh:
        line_no += 1
        line = raw.strip()
        if not line:
            continue
        if line.startswith('#'):
            body = line[1:].strip()
            if ':' in body:
                key, _, val = body.partition(':')
                meta[key.strip()] = val.strip()
            continue
        names = [c.strip() for c in line.split(',')]
        for col in COLUMNS:
            if col not in names:
                raise MissingColumnError(
                    f'{path}: missing column {col!r} in the header on line {line_no} '
                    f'(expected {",".join(COLUMNS)})'
                )
        if len(set(names)) != len(names):
            raise InvalidDataError(f'{path}: duplicate column names on line {line_no}')
        return names, meta, line_no
    raise TooShortError(f'{path}: no header line (expected {",".join(COLUMNS)})')


def _parse_rows(
    lines: list[str], numbers: list[int], names: list[str], path: Path, use: list[int]
) -> np.ndarray:
    ncol = len(names)
    try:
        data = np.loadtxt(lines, delimiter=',', dtype=float, ndmin=2, usecols=use)
        if data.shape[1] != len(use):
            raise ValueError
        return data
    except ValueError:
        pass
    # locate the bad line for the message
    for text, no in zip(lines, numbers, strict=True):
        cells = text.split(',')
        if len(cells) != ncol:
            raise InvalidDataError(
                f'{path}: line {no} has {len(cells)} fields, the header has {ncol}'
            )
        for cell, name in zip(cells, names, strict=True):
            try:
                float(cell)
            except ValueError:
                raise InvalidDataError(
                    f'{path}: line {no}, column {name!r}: {cell.strip()!r} is not a number'
                ) from None
    raise InvalidDataError(f'{path}: cannot parse lines {numbers[0]}-{numbers[-1]}')


def _check_block(
    data: np.ndarray,
    numbers: np.ndarray,
    names: list[str],
    path: Path,
    last_time: float,
    max_speed: float | None,
) -> None:
    bad = ~np.isfinite(data)
    if bad.any():
        r, c = np.argwhere(bad)[0]
        raise InvalidDataError(
            f'{path}: line {numbers[r]}, column {names[c]!r}: non-finite value {float(data[r, c])}'
        )
    t = data[:, names.index('time')]
    steps = np.diff(np.concatenate([[last_time], t])) if np.isfinite(last_time) else np.diff(t)
    off = 0 if np.isfinite(last_time) else 1
    nonpos = np.flatnonzero(steps <= 0.0)
    if nonpos.size:
        i = nonpos[0] + off
        raise NonMonotonicTimeError(
            f'{path}: line {numbers[i]}: time {float(t[i])!r} s does not increase '
            f'(previous sample {float(t[i - 1] if i > 0 else last_time)!r} s)'
        )
    if max_speed is not None:
        sp = data[:, names.index('speed')]
        big = np.flatnonzero(np.abs(sp) > max_speed)
        if big.size:
            i = big[0]
            raise UnitError(
                f"{path}: line {numbers[i]}, column 'speed': {float(sp[i])!r} exceeds "
                f'the plausible '
                f'{max_speed} rad/s of the rig; the speed looks like rpm (convert: '
                f'rad/s = rpm*pi/30)'
            )


def _block(data: np.ndarray, names: list[str], meta: dict[str, str], first_line: int) -> CsvBlock:
    cols = {n: np.ascontiguousarray(data[:, i]) for i, n in enumerate(names)}
    return CsvBlock(
        time=cols.pop('time'),
        torsion_moment=cols.pop('torsion_moment'),
        angular_acceleration=cols.pop('angular_acceleration'),
        speed=cols.pop('speed'),
        extra=cols,
        metadata=dict(meta),
        first_line=first_line,
    )


def iter_rig_csv(
    path: str | Path,
    block_size: int = 10_000,
    *,
    max_speed: float | None = MAX_SPEED,
    extra: bool = True,
) -> Iterator[CsvBlock]:
    """Yield the file in blocks of up to ``block_size`` lines, checking every value.

    Time must increase across block boundaries too. ``max_speed`` [rad/s]: speeds of
    larger magnitude raise :class:`UnitError` (``None`` switches the check off).
    ``extra``: also read the columns after the four channels (else they are skipped
    unread). Bytes that are not UTF-8 raise :class:`InvalidDataError` naming the file.
    """
    p = Path(path)
    try:
        yield from _iter_rig_csv(p, block_size, max_speed, extra)
    except UnicodeDecodeError as exc:
        raise InvalidDataError(
            f'{p}: not a UTF-8 text rig CSV (undecodable byte {exc.object[exc.start]:#04x})'
        ) from None


def _data_lines(batch: list[str], first: int) -> tuple[list[str], list[int]]:
    """Return the data lines of a batch of file lines and their line numbers (1-based)."""
    lines: list[str] = []
    numbers: list[int] = []
    for k, raw in enumerate(batch):
        s = raw.strip()
        if s and not s.startswith('#'):
            lines.append(s)
            numbers.append(first + k)
    return lines, numbers


def _iter_rig_csv(
    p: Path, block_size: int, max_speed: float | None, extra: bool
) -> Iterator[CsvBlock]:
    if block_size < 1:
        raise InvalidDataError(f'block_size must be >= 1, got {block_size}')
    try:
        fh = p.open('r', encoding='utf-8')
    except OSError as exc:
        raise InvalidDataError(f'{p}: cannot open rig CSV ({exc.strerror})') from exc
    with fh:
        names, meta, line_no = _parse_header(fh, p)
        use = list(range(len(names))) if extra else [names.index(c) for c in COLUMNS]
        used = [names[i] for i in use]
        last_time = float('nan')
        any_rows = False
        while batch := list(itertools.islice(fh, block_size)):
            first = line_no + 1
            line_no += len(batch)
            # fast path: a batch of data lines only (comments and blank lines are rare)
            lines, numbers = batch, list(range(first, first + len(batch)))
            if '#' in ''.join(batch):
                lines, numbers = _data_lines(batch, first)
            if not lines:
                continue
            data = _parse_rows(lines, numbers, names, p, use)
            if data.shape[0] != len(lines):  # blank lines inside the batch
                lines, numbers = _data_lines(batch, first)
                data = _parse_rows(lines, numbers, names, p, use)
            _check_block(data, np.asarray(numbers), used, p, last_time, max_speed)
            last_time = float(data[-1, used.index('time')])
            any_rows = True
            yield _block(data, used, meta, numbers[0])
        if not any_rows:
            raise TooShortError(f'{p}: no data rows after the header')


def read_rig_csv(path: str | Path, *, max_speed: float | None = MAX_SPEED) -> CsvBlock:
    """Read a whole rig CSV file (for long files prefer :func:`iter_rig_csv`)."""
    blocks = list(iter_rig_csv(path, 100_000, max_speed=max_speed))
    if len(blocks) == 1:
        return blocks[0]
    extra_names = list(blocks[0].extra)
    return CsvBlock(
        time=np.concatenate([b.time for b in blocks]),
        torsion_moment=np.concatenate([b.torsion_moment for b in blocks]),
        angular_acceleration=np.concatenate([b.angular_acceleration for b in blocks]),
        speed=np.concatenate([b.speed for b in blocks]),
        extra={n: np.concatenate([b.extra[n] for b in blocks]) for n in extra_names},
        metadata=blocks[0].metadata,
        first_line=blocks[0].first_line,
    )


# ----------------------------------------------------------------------------- time base
#: Largest distance of a sample time from the regular grid [sample intervals];
#: closer samples are resampled onto the grid, farther ones are irregular sampling.
JITTER_TOL = 0.25
#: Jitter below this fraction of the sample interval is snapped, not interpolated.
JITTER_SNAP = 0.01


def estimate_rate(t: np.ndarray, source: str = '<record>') -> float:
    """Sample rate [Hz] of strictly increasing times ``t`` [s] (epoch or relative).

    The median step gives each sample's grid index; a least-squares line of time on
    index gives the interval (jitter and epoch rounding average out); the rate is
    rounded to 6 significant digits.
    """
    t = np.asarray(t, dtype=np.float64)
    if t.shape[0] < 2:
        raise TooShortError(f'{source}: need at least two samples to find the sample rate')
    rel = t - t[0]
    dt0 = float(np.median(np.diff(rel)))
    if not (math.isfinite(dt0) and dt0 > 0.0):
        raise TimeBaseError(f'{source}: time steps give no sample rate (median step {dt0} s)')
    dt = dt0
    n = min(rel.shape[0], 64)
    while True:  # refine on growing prefixes so a slightly wrong step never skips an index
        idx = np.rint(rel[:n] / dt)
        di = idx - idx.mean()
        den = float(np.dot(di, di))
        if den > 0.0:
            dt = float(np.dot(di, rel[:n] - rel[:n].mean()) / den)
        if n == rel.shape[0] or not (math.isfinite(dt) and dt > 0.0):
            break
        n = min(rel.shape[0], n * 8)
    if not (math.isfinite(dt) and dt > 0.0):
        raise TimeBaseError(f'{source}: time steps give no sample rate')
    return float(f'{1.0 / dt:.6g}')


def centred_anchor(t: np.ndarray, fs: float) -> float:
    """Return the grid time [s] of the first sample of ``t`` [s].

    The grid is placed so that the stamps' offsets from it have median zero (a
    jittered first stamp does not shift the grid).
    """
    pos = (np.asarray(t, dtype=np.float64) - float(t[0])) * fs
    off = float(np.median(pos - np.rint(pos))) if pos.size else 0.0
    return float(t[0]) + off / fs


def grid_positions(
    t: np.ndarray,
    fs: float,
    t_ref: float,
    idx_ref: int,
    source: str = '<record>',
    lines: np.ndarray | None = None,
    after: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Grid index of each time ``t`` [s] and its offset from the grid [samples].

    The grid has index ``idx_ref`` at time ``t_ref`` (when streaming, the grid time
    of the previous chunk's last sample, so a rate wrong in its last digits never
    accumulates); ``after``: index of the previous chunk's last sample (the first
    index must be larger). Raises :class:`IrregularSamplingError` naming the time and the
    line (``lines``: file line of each sample) where a sample lies more than
    :data:`JITTER_TOL` intervals off the grid or two samples share one grid point.
    """
    pos = idx_ref + (np.asarray(t, dtype=np.float64) - t_ref) * fs
    idx = np.rint(pos)
    frac = pos - idx
    bad = np.flatnonzero(np.abs(frac) > JITTER_TOL)
    prev = float(after) if after is not None else float(idx[0]) - 1.0 if idx.size else 0.0
    dup = np.flatnonzero(np.diff(np.concatenate([[prev], idx])) < 1)
    if bad.size or dup.size:
        i = int(min(bad[0] if bad.size else len(t), dup[0] if dup.size else len(t)))
        where = f'line {int(lines[i])}, ' if lines is not None else f'sample {i + 1}, '
        raise IrregularSamplingError(
            f'{source}: {where}time {float(t[i])!r} s is {float(frac[i]):+.2f} sample '
            f'intervals off the regular {fs:g} Hz grid (irregular sampling; jitter up to '
            f'{JITTER_TOL:.0%} of the interval is resampled)'
        )
    return idx.astype(np.int64), frac


def resample_on_grid(idx: np.ndarray, frac: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Interpolate ``values`` at the grid points ``idx``.

    Linear interpolation between the samples at ``idx + frac`` [samples];
    ``values`` is returned unchanged where the jitter is below :data:`JITTER_SNAP`.
    """
    if frac.size == 0 or float(np.max(np.abs(frac))) < JITTER_SNAP:
        return values
    pos = idx + frac
    out: np.ndarray = np.interp(idx.astype(np.float64), pos, values)
    return out
