"""The block table ``blocks.csv``: its columns, a streaming writer and a reader.

:func:`read_blocks_csv` and :func:`results_table` give the same column arrays,
from a file and from :class:`.results.BlockResult` objects in memory.
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Iterable
from typing import TextIO

import numpy as np

from ...errors import InvalidDataError, MissingColumnError
from .results import BlockResult

#: Block-table columns shared with the live estimates (FrictionEstimate) and the
#: report, then ``quality``.
CSV_COLUMNS: tuple[str, ...] = (
    't_start',
    't_end',
    'mu0',
    'mu_inf',
    'mu0_se',
    'mu_inf_se',
    'moment_min',
    'moment_max',
    'moment_mean',
    'motion',
    'n_sticks',
    'stick_fraction',
    'rms_residual',
    'quality',
)

#: Columns of the ``blocks.csv`` file: :data:`CSV_COLUMNS` plus the drive speed the
#: fit used (``w0`` [rad/s], measured) and its relative deviation from the
#: configured nominal speed (``drive_mismatch`` [-]), the speed channel's offset from the
#: stick lines' drive speed (``speed_offset`` [rad/s]) before ``quality``, and after it
#: the repairs of each block (``spikes``: samples replaced before the fit and left
#: out of it, ``bursts``: runs of 3 or more of them; :mod:`..plausibility`). Older
#: files without these are read too.
FILE_COLUMNS: tuple[str, ...] = (
    *CSV_COLUMNS[:-1],
    'w0',
    'drive_mismatch',
    'speed_offset',
    'quality',
    'spikes',
    'bursts',
)
REQUIRED_COLUMNS = CSV_COLUMNS


def _fmt(v: float) -> str:
    return 'nan' if not math.isfinite(v) else repr(float(v))  # round-trip: epoch stamps


def block_row(r: BlockResult) -> dict[str, float | int | str]:
    """Return one row of ``blocks.csv`` as plain values (:data:`FILE_COLUMNS` order).

    Parameters
    ----------
    r : BlockResult
        The block.

    Returns
    -------
    dict
        Column name -> value (SI; ``quality`` ``ok`` or the ``;``-joined flags).
    """
    row: dict[str, float | int | str] = {}
    for c in FILE_COLUMNS:
        if c == 'quality':
            row[c] = r.quality_str
        elif c == 'motion':
            row[c] = r.motion
        elif c in ('n_sticks', 'spikes', 'bursts'):
            row[c] = int(getattr(r, c))
        else:
            row[c] = float(getattr(r, c))
    return row


class BlockCsvWriter:
    """Write :class:`BlockResult` rows to ``blocks.csv`` as they come (streaming).

    Each row is flushed, so a run that is interrupted keeps every finished block.
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = os.fspath(path)
        self._fh: TextIO = open(self.path, 'w', newline='', encoding='utf-8')  # noqa: SIM115
        self._w = csv.writer(self._fh, lineterminator='\n')
        self._w.writerow(FILE_COLUMNS)
        self._fh.flush()
        self.rows = 0

    def write(self, r: BlockResult) -> None:
        """Append one block."""
        self._w.writerow(
            [
                v if isinstance(v, str) else _fmt(v) if isinstance(v, float) else str(v)
                for v in block_row(r).values()
            ]
        )
        self._fh.flush()
        self.rows += 1

    def close(self) -> None:
        """Close the file."""
        self._fh.close()

    def __enter__(self) -> BlockCsvWriter:
        """Return the writer (context manager)."""
        return self

    def __exit__(self, *exc: object) -> None:
        """Close the file."""
        self.close()


def read_blocks_csv(path: str | os.PathLike[str]) -> dict[str, np.ndarray]:
    """Read a ``blocks.csv`` into column arrays (float for numbers, object for text).

    Raises
    ------
    MissingColumnError
        a required column is missing (named in the message).
    InvalidDataError
        the file cannot be read or a number column holds text.
    """
    p = os.fspath(path)
    try:
        fh = open(p, newline='', encoding='utf-8')  # noqa: SIM115
    except OSError as exc:
        raise InvalidDataError(f'{p}: cannot read blocks table ({exc.strerror})') from exc
    with fh:
        reader = csv.DictReader(fh)
        cols = reader.fieldnames or []
        for c in REQUIRED_COLUMNS:
            if c not in cols:
                raise MissingColumnError(f'{p}: missing column {c!r} in blocks table')
        rows = list(reader)
    out: dict[str, np.ndarray] = {}
    for c in FILE_COLUMNS:
        vals = [r.get(c) or 'nan' for r in rows]
        if c in ('motion', 'quality'):
            out[c] = np.array(vals, dtype=object)
        else:
            try:
                out[c] = np.array([float(v) for v in vals], dtype=float)
            except ValueError as exc:
                raise InvalidDataError(f'{p}: column {c!r} has a non-numeric value') from exc
    return out


def results_table(results: Iterable[BlockResult]) -> dict[str, np.ndarray]:
    """Column arrays (as :func:`read_blocks_csv` gives) from results in memory."""
    rs = list(results)
    out: dict[str, np.ndarray] = {}
    for c in CSV_COLUMNS:
        if c == 'quality':
            out[c] = np.array([r.quality_str for r in rs], dtype=object)
        elif c == 'motion':
            out[c] = np.array([r.motion for r in rs], dtype=object)
        else:
            out[c] = np.array([float(getattr(r, c)) for r in rs], dtype=float)
    return out
