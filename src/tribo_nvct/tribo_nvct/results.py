"""Typed result of the nVCT wear evaluation (:func:`tribo_nvct.evaluate_wear`).

As :mod:`tribo_estimation.results`: ``rows()`` (one plain dict per dwell),
``to_frame()`` (pandas, imported then), ``write(dir)`` (the files ``tribo wear``
writes), ``plot(dir)`` (Fig. 10/11) and ``summary()``. Units: SI in the fields;
the files and the summary use the CLI's display units (um^3, nm, min), named in
their keys.
"""

from __future__ import annotations

import csv
import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import pandas as pd

    from tribo_nvct.core.config import NvctConfig
    from tribo_nvct.core.evaluation import Evaluation
    from tribo_nvct.core.wear import WearPoint

PathLike = str | os.PathLike[str]
#: m^3 per um^3 (display unit of wear volumes).
UM3 = 1e-18
#: Columns of ``wear.csv`` (one row per dwell).
WEAR_COLUMNS: tuple[str, ...] = (
    't',
    't_start',
    't_end',
    'wear_volume_um3',
    'wear_volume_se_um3',
    'wear_volume_sys_se_um3',
    'wear_height_nm',
    'wear_height_se_nm',
    'tagged_volume_um3',
    'tagged_volume_se_um3',
    'activity_bq',
    'activity_se_bq',
    'counts',
    'live_time',
    'usable',
    'quality',
)
#: Flags counted in the summary.
COUNTED_FLAGS = ('not_mixed', 'beyond_profile', 'below_detection_limit', 'gap')


def _jsonable(x: object) -> object:
    """NaN/inf -> None so the JSON is strict."""
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_jsonable(v) for v in x]
    return x


@dataclass(frozen=True, eq=False)
class WearResult:
    """Wear of one nVCT test (paper section 3, Equ. 8-10).

    Attributes
    ----------
    config : NvctConfig
        The test's configuration (nuclide, depth profile, contact, load, stroke).
    points : tuple of WearPoint
        One wear state per dwell (volume [m^3], height [m], activity [Bq], flags).
    evaluation : Evaluation
        Running-in vs progressive wear, wear coefficients, the exponential model.
    source : str
        The counts file or bag.
    repeated : int
        Dwells given twice (ignored) [-].
    truncated : str
        The error of a bag that ended early ('' if none).
    config_file : str
        The NVCT.yaml the config came from ('' if built in memory).
    dwell_time : float
        Median real time of the dwells [s] (NaN: none).
    """

    config: NvctConfig
    points: tuple[WearPoint, ...]
    evaluation: Evaluation
    source: str
    repeated: int = 0
    truncated: str = ''
    config_file: str = ''
    dwell_time: float = math.nan

    FILES = ('wear.csv', 'summary.json')
    FIGURES = ('wear.png',)

    def rows(self) -> list[dict[str, float | int | str]]:
        """Return one plain dict per dwell (the ``wear.csv`` columns, display units).

        Returns
        -------
        list of dict
            Test time [s], volumes [um^3], heights [nm], activity [Bq], counts,
            live time [s], usable, quality.
        """
        return [
            {
                't': p.t_end,
                't_start': p.t_start,
                't_end': p.t_end,
                'wear_volume_um3': p.volume / UM3,
                'wear_volume_se_um3': p.volume_se / UM3,
                'wear_volume_sys_se_um3': p.volume_sys_se / UM3,
                'wear_height_nm': p.height * 1e9,
                'wear_height_se_nm': p.height_se * 1e9,
                'tagged_volume_um3': p.tagged_volume / UM3,
                'tagged_volume_se_um3': p.tagged_volume_se / UM3,
                'activity_bq': p.activity,
                'activity_se_bq': p.activity_se,
                'counts': p.counts,
                'live_time': p.live_time,
                'usable': int(p.usable),
                'quality': p.quality,
            }
            for p in self.points
        ]

    def to_frame(self) -> pd.DataFrame:
        """Return :meth:`rows` as a pandas DataFrame.

        Returns
        -------
        pandas.DataFrame
            One row per dwell.
        """
        import pandas as pd

        rows = self.rows()
        return pd.DataFrame(rows, columns=list(WEAR_COLUMNS))

    def summary(self) -> dict[str, object]:
        """Return the numbers of ``summary.json`` (display units named in the keys).

        Returns
        -------
        dict
            The evaluation's summary (volumes, rates, k_w, the exponential model)
            plus the test's configuration and the dwells' bookkeeping.
        """
        cfg = self.config
        pts = self.points
        dwell_s = self.dwell_time if math.isfinite(self.dwell_time) else None
        out = dict(self.evaluation.summary(cfg, dwell_s))
        out.update(
            {
                'input': self.source,
                'nvct_config': self.config_file,
                'label': cfg.label,
                'nuclide': cfg.nuclide.name,
                'tagged_activity_bq': cfg.tagged_activity,
                'tagged_area_um2': cfg.tagged_area / 1e-12,
                'contact_area_um2': cfg.contact_area / 1e-12,
                'k_A': cfg.k_A,
                'load_N': cfg.load,
                'stroke_m': cfg.stroke,
                'frequency_hz': cfg.frequency,
                'temperature_K': cfg.temperature_K,
                'dwells': len(pts),
                'repeated_dwells_ignored': self.repeated,
                'input_truncated': self.truncated or None,
                'not_mixed_until_s': cfg.circuit.mixing_time if cfg.circuit else 0.0,
                'flag_counts': {f: sum(1 for p in pts if f in p.flags) for f in COUNTED_FLAGS},
                'systematic_relative_se_at_end': (
                    pts[-1].volume_sys_se / pts[-1].volume
                    if pts and math.isfinite(pts[-1].volume) and pts[-1].volume > 0
                    else math.nan
                ),
            }
        )
        if cfg.contact is not None:
            c = cfg.contact
            out['contact'] = {
                'kind': c.kind,
                'half_width_circ_mm': c.half_width_circ * 1e3,
                'half_width_axial_mm': c.half_width_axial * 1e3,
                'p_max_MPa': c.p_max / 1e6,
                'p_mean_MPa': c.p_mean / 1e6,
                'eccentricity': c.eccentricity,
            }
        return out

    def write(self, directory: PathLike) -> list[Path]:
        """Write ``wear.csv`` and ``summary.json`` (as ``tribo wear`` does).

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
        with (d / 'wear.csv').open('w', newline='', encoding='utf-8') as fh:
            fh.write(
                '# units: t, t_start, t_end, live_time in s (test time); volumes um^3; '
                'heights nm;\n'
            )
            fh.write('# activity Bq at the depth-profile reference date; quality: ok or flags\n')
            w = csv.writer(fh)
            w.writerow(WEAR_COLUMNS)
            for r in self.rows():
                w.writerow([_cell(k, r[k]) for k in WEAR_COLUMNS])
        (d / 'summary.json').write_text(
            json.dumps(_jsonable(self.summary()), indent=2, allow_nan=False) + '\n',
            encoding='utf-8',
        )
        return [d / f for f in self.FILES]

    def plot(self, directory: PathLike) -> list[Path]:
        """Draw ``wear.png`` (Fig. 10/11: wear volume over test time).

        Parameters
        ----------
        directory : str or PathLike
            Output directory (created if needed).

        Returns
        -------
        list of Path
            The figure written.
        """
        from tribo_nvct.plots import plot_wear_run

        d = Path(directory)
        d.mkdir(parents=True, exist_ok=True)
        return [plot_wear_run(d / 'wear.png', list(self.points), self.evaluation, self.config)]


def _cell(name: str, v: float | int | str) -> str:
    """Format one ``wear.csv`` cell as the file has always been written."""
    if isinstance(v, str):
        return v
    if name in ('counts', 'usable'):
        return str(int(v))
    if name in ('t', 't_start', 't_end'):
        return f'{v:.3f}'
    if name == 'live_time':
        return f'{v:.6f}'
    return f'{v:.6g}'
