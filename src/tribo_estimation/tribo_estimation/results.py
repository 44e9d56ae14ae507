"""Typed results of the Python API (:mod:`tribo_estimation.api`).

Each result carries its numbers as typed fields and offers, in the manner of
python-control's response objects:

- ``rows()``: a list of plain dicts (one per block, effect, parameter set);
- ``to_frame()``: the rows as a pandas DataFrame (pandas is imported then);
- ``write(directory)``: the result files the matching ``tribo`` command writes;
- ``plot(directory)``: the command's figures (matplotlib is imported then);
- ``summary()``: the headline numbers as a flat mapping (SI; keys name the unit
  where it is not SI).

Units: SI throughout (moments N m, speeds rad/s, times s, coefficients -).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import pandas as pd

    from tribo_estimation.core.blockfit import BlockConfig, BlockResult
    from tribo_estimation.core.blockfit.figdata import FigureData
    from tribo_estimation.core.decay import DecayResult
    from tribo_estimation.core.record import RigRecord

PathLike = str | os.PathLike[str]
#: A plain value of a result row.
Cell = float | int | str | bool | None


def frame(rows: Sequence[dict[str, Cell]], columns: Sequence[str] = ()) -> pd.DataFrame:
    """Return rows as a pandas DataFrame (the one place the results import pandas).

    Parameters
    ----------
    rows : sequence of dict
        Plain rows.
    columns : sequence of str
        Column order when there are no rows.

    Returns
    -------
    pandas.DataFrame
        One row per dict.
    """
    import pandas as pd

    return pd.DataFrame(list(rows), columns=list(columns) if not rows and columns else None)


def _json_value(x: object) -> object:
    """NaN/inf -> None, containers recursively (strict JSON)."""
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, dict):
        return {str(k): _json_value(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_json_value(v) for v in x]
    return x


def write_json(path: Path, data: dict[str, object]) -> Path:
    """Write strict, indented JSON (NaN as null) and return the path.

    Parameters
    ----------
    path : Path
        File to write.
    data : dict
        The content.

    Returns
    -------
    Path
        ``path``.
    """
    path.write_text(
        json.dumps(_json_value(data), indent=2, allow_nan=False) + '\n', encoding='utf-8'
    )
    return path


# ----------------------------------------------------------------------------- block fit
@dataclass(frozen=True, eq=False)
class BlockFit:
    """Block-wise friction estimates of a record (paper section 2.5, Equ. 8).

    Attributes
    ----------
    results : tuple of BlockResult
        One per block, in time order (mu0, mu_inf [-], their SE, k [s/rad], the
        torsion-moment envelope [N m], motion type, quality flags, ...).
    config : BlockConfig
        The settings of the fit (block length [s], fit_k, nominal speed [rad/s]).
    k : float
        Stribeck constant of the rig config [s/rad] (curves of the mu-slip figure).
    nominal_speed : float
        Drive speed of the rig config [rad/s].
    source : str
        The input (file, bag, ``<record>``).
    figures : FigureData
        What :meth:`plot` draws (observer samples, detail windows).
    warnings : tuple of str
        Warnings of the input checks.
    replaced : int
        Samples replaced by the input checks (spikes, bursts) [-].
    max_jitter : float
        Largest stamp jitter of a CSV [sample intervals].
    truncated : str
        The error of a bag that ended early ('' if none): the blocks before it.
    """

    results: tuple[BlockResult, ...]
    config: BlockConfig
    k: float
    nominal_speed: float
    source: str
    figures: FigureData
    warnings: tuple[str, ...] = ()
    replaced: int = 0
    max_jitter: float = 0.0
    truncated: str = ''

    #: Files of :meth:`write` and :meth:`plot`.
    FILES = ('blocks.csv',)
    FIGURES = ('blocks.png', 'mu_slip.png', 'detail.png')

    def __len__(self) -> int:
        """Return the number of blocks."""
        return len(self.results)

    @property
    def ok(self) -> tuple[BlockResult, ...]:
        """The blocks whose quality is ``ok``."""
        return tuple(r for r in self.results if r.ok)

    def rows(self) -> list[dict[str, Cell]]:
        """Return one plain dict per block (the ``blocks.csv`` columns, NaN kept).

        Returns
        -------
        list of dict
            Column name -> value.
        """
        from tribo_estimation.core.blockfit import block_row

        return [dict(block_row(r)) for r in self.results]

    def to_frame(self) -> pd.DataFrame:
        """Return :meth:`rows` as a pandas DataFrame.

        Returns
        -------
        pandas.DataFrame
            One row per block.
        """
        from tribo_estimation.core.blockfit import FILE_COLUMNS

        return frame(self.rows(), FILE_COLUMNS)

    def write(self, directory: PathLike) -> list[Path]:
        """Write ``blocks.csv`` (as ``tribo friction`` does) into ``directory``.

        Parameters
        ----------
        directory : str or PathLike
            Output directory (created if needed).

        Returns
        -------
        list of Path
            The files written.
        """
        from tribo_estimation.core.blockfit import BlockCsvWriter

        d = Path(directory)
        d.mkdir(parents=True, exist_ok=True)
        with BlockCsvWriter(d / 'blocks.csv') as w:
            for r in self.results:
                w.write(r)
        return [d / 'blocks.csv']

    def plot(self, directory: PathLike, title: str = 'friction per block') -> list[Path]:
        """Draw ``blocks.png`` (Fig. 4/5), ``mu_slip.png`` and ``detail.png`` (Fig. 6).

        Parameters
        ----------
        directory : str or PathLike
            Output directory (created if needed).
        title : str
            Title of the block figure.

        Returns
        -------
        list of Path
            The figures written.
        """
        from tribo_estimation.core.blockfit import results_table
        from tribo_estimation.plots import plot_blocks, plot_detail, plot_mu_slip

        d = Path(directory)
        d.mkdir(parents=True, exist_ok=True)
        table = results_table(self.results)
        plot_blocks(table, d / 'blocks.png', title=title)
        v, mu = self.figures.points()
        ks = np.array([r.k for r in self.results], dtype=float)
        plot_mu_slip(table, d / 'mu_slip.png', ks if ks.size else self.k, v, mu)
        plot_detail(self.figures.traces(), d / 'detail.png')
        return [d / f for f in self.FIGURES]

    def summary(self) -> dict[str, Cell]:
        """Return the headline numbers of the fit.

        Returns
        -------
        dict
            ``blocks``, ``blocks_ok``, ``block_length_s``, min/mean/max of mu0 and
            mu_inf over the good blocks [-], ``replaced_samples``, ``source``.
        """
        good = self.ok
        out: dict[str, Cell] = {
            'blocks': len(self.results),
            'blocks_ok': len(good),
            'block_length_s': self.config.block_length,
        }
        for name in ('mu0', 'mu_inf'):
            v = np.array([getattr(r, name) for r in good], dtype=float)
            v = v[np.isfinite(v)]
            for stat, f in (('min', np.min), ('mean', np.mean), ('max', np.max)):
                out[f'{name}_{stat}'] = float(f(v)) if v.size else None
        out['replaced_samples'] = self.replaced
        out['source'] = self.source
        return out

    def notices(self) -> list[str]:
        """Return the warnings about the drive level the fit found (one line each).

        A drive speed off the config's nominal speed by more than
        :data:`~tribo_estimation.core.drive.MISMATCH_LIMIT`, and a speed channel
        whose level the stick lines corrected.

        Returns
        -------
        list of str
            Warnings naming the blocks and the ``blocks.csv`` columns.
        """
        from tribo_estimation.core.blockfit.evaluate import SPEED_CHANNEL_TOL
        from tribo_estimation.core.drive import MISMATCH_LIMIT

        out: list[str] = []
        off = [
            r
            for r in self.results
            if 'startup' not in r.quality
            and math.isfinite(r.drive_mismatch)
            and abs(r.drive_mismatch) > MISMATCH_LIMIT
        ]
        if off:
            worst = max(off, key=lambda r: abs(r.drive_mismatch))
            out.append(
                f'the drive speed of {len(off)} block(s) differs from the RIG.yaml '
                f'nominal_speed {self.nominal_speed:.4g} rad/s by more than '
                f'{100 * MISMATCH_LIMIT:.0f} % (worst: block {worst.index}, {worst.w0:.4g} rad/s, '
                f'{100 * worst.drive_mismatch:+.1f} %); the measured drive speed is used '
                '(blocks.csv columns w0, drive_mismatch)'
            )
        corrected = [
            r
            for r in self.results
            if math.isfinite(r.speed_offset)
            and math.isfinite(r.w0)
            and abs(r.speed_offset) > SPEED_CHANNEL_TOL * abs(r.w0)
        ]
        if corrected:
            med = float(np.median([r.speed_offset for r in corrected]))
            out.append(
                f'the speed channel reads {med:+.3g} rad/s off the drive speed the stick lines '
                f'show, in {len(corrected)} block(s) (a tachometer offset or gain error); the '
                'drive level of those blocks is taken from the stick lines (blocks.csv column '
                'speed_offset)'
            )
        return out


# ----------------------------------------------------------------------------- discrepancy
# The missing-physics pipeline's result lives in its own module; this module re-exports it
# on first use (PEP 562), so importing the results does not import the pipeline.
if TYPE_CHECKING:
    from tribo_estimation.core.discrepancy.pipeline.result import (
        MissingPhysics as MissingPhysics,
    )


def __getattr__(name: str) -> object:
    """Return :class:`MissingPhysics` on first use (the pipeline imported then)."""
    if name == 'MissingPhysics':
        from tribo_estimation.core.discrepancy.pipeline.result import MissingPhysics

        return MissingPhysics
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')


# ----------------------------------------------------------------------------- decay
#: Units of the decay identification's values (``decay.json``).
DECAY_UNITS: dict[str, str] = {
    'I1': 'kg m^2',
    'K1': 'N m s/rad',
    'C1': 'N m/rad',
    'f_n_hz': 'Hz',
    'zeta': '-',
    'torque_offset': 'N m',
    'accel_offset': 'rad/s^2',
}


@dataclass(frozen=True, eq=False)
class DecayFit:
    """The chamber identified from a free decay (paper Equ. 7).

    Attributes
    ----------
    result : DecayResult
        I1 [kg m^2], K1 [N m s/rad], C1 [N m/rad], f_n [Hz], zeta [-] and their SE.
    record : RigRecord
        The record it was identified from (after the input checks).
    """

    result: DecayResult
    record: RigRecord = field(repr=False)

    FILES = ('decay.json',)
    FIGURES = ('decay.png',)

    def as_dict(self) -> dict[str, object]:
        """Return the content of ``decay.json``.

        Returns
        -------
        dict
            The identified values and SE, ``units``, ``input`` (the source) and
            ``time_origin_s`` (stamp of the record's time 0 [s]).
        """
        return {
            **self.result.to_dict(),
            'units': dict(DECAY_UNITS),
            'input': self.record.source,
            'time_origin_s': self.record.time_origin,
        }

    def rows(self) -> list[dict[str, Cell]]:
        """Return one row per identified value: ``name``, ``value``, ``se``, ``unit``.

        Returns
        -------
        list of dict
            I1, K1, C1, f_n_hz, zeta.
        """
        d = self.result.to_dict()
        return [
            {'name': n, 'value': float(d[n]), 'se': float(d[f'{n}_se']), 'unit': DECAY_UNITS[n]}
            for n in ('I1', 'K1', 'C1', 'f_n_hz', 'zeta')
        ]

    def to_frame(self) -> pd.DataFrame:
        """Return :meth:`rows` as a pandas DataFrame.

        Returns
        -------
        pandas.DataFrame
            One row per identified value.
        """
        return frame(self.rows(), ('name', 'value', 'se', 'unit'))

    def write(self, directory: PathLike) -> list[Path]:
        """Write ``decay.json`` (as ``tribo decay`` does) into ``directory``.

        Parameters
        ----------
        directory : str or PathLike
            Output directory (created if needed).

        Returns
        -------
        list of Path
            The files written.
        """
        d = Path(directory)
        d.mkdir(parents=True, exist_ok=True)
        return [write_json(d / 'decay.json', self.as_dict())]

    def plot(self, directory: PathLike) -> list[Path]:
        """Draw ``decay.png``: the record's torsion moment and acceleration.

        Parameters
        ----------
        directory : str or PathLike
            Output directory (created if needed).

        Returns
        -------
        list of Path
            The figure written.
        """
        from tribo_estimation.plots import plot_record

        d = Path(directory)
        d.mkdir(parents=True, exist_ok=True)
        r = self.result
        title = f'free decay: f_n = {r.f_n_hz:.4g} Hz, zeta = {r.zeta:.3g}'
        plot_record(self.record, d / 'decay.png', title=title)
        return [d / 'decay.png']

    def summary(self) -> dict[str, Cell]:
        """Return the identified values [their units].

        Returns
        -------
        dict
            I1, K1, C1, f_n_hz, zeta and their ``*_se``.
        """
        d = self.result.to_dict()
        return {k: float(v) for k, v in d.items() if k.split('_se')[0] in DECAY_UNITS}
