"""A generated scenario: the measured record, its truth, the user's config, the labels.

Files a person (or the bench) hands to ``tribo discrepancy``:
:meth:`Scenario.write_csv` (rig CSV, header ``time,torsion_moment,angular_acceleration,speed``),
:meth:`Scenario.write_rig_yaml` (the RIG.yaml a lab would pass) and
:meth:`Scenario.write_truth_json` (what was hidden; never given to the workflow).
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from .errors import OutputError
from .spec import ScenarioSpec

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

#: Key order of the written RIG.yaml (that of ``config/rig.yaml``), with units.
RIG_KEYS: tuple[tuple[str, str], ...] = (
    ('I1', 'kg m^2'),
    ('K1', 'N m s/rad'),
    ('C1', 'N m/rad'),
    ('I2', 'kg m^2'),
    ('K2', 'N m s/rad'),
    ('C2', 'N m/rad'),
    ('F_N', 'N'),
    ('R', 'm'),
    ('mu0', '-'),
    ('mu_inf', '-'),
    ('k', 's/rad'),
    ('nominal_speed', 'rad/s'),
    ('ramp_time', 's'),
    ('noise_torque', 'N m'),
    ('noise_accel', 'rad/s^2'),
    ('noise_speed', 'rad/s'),
)


@dataclass(frozen=True)
class Truth:
    """What the record hides.

    ``effect`` 'none', the library family or 'out_of_library:<name>'; ``category``
    'none', 'library', 'out_of_library'; ``name`` and ``form`` of the effect;
    ``params`` its parameters (SI, :mod:`.space`); ``library_params`` the same under
    the library candidate's names when ``own_form``; ``effect_snr`` the rms change of
    the measured torsion moment it causes (mean removed) over the white torque noise
    [-] (0 for none); ``noise_rms`` the rms of the noise added to each channel
    (white + coloured + hum; N m, rad/s^2, rad/s).
    """

    effect: str
    category: str
    name: str
    form: str
    params: dict[str, float]
    library_params: dict[str, float]
    own_form: bool
    effect_snr: float
    noise_rms: dict[str, float]


@dataclass(frozen=True, eq=False)
class Scenario:
    """A generated record with its truth.

    ``time`` [s] from the first sample, ``torsion_moment`` [N m],
    ``angular_acceleration`` [rad/s^2], ``speed`` [rad/s] (measured, float64);
    ``fs`` [Hz]; ``stick`` the true stick flag per sample; ``gen_seconds`` the
    simulation's wall time when it was made [s]; ``from_cache`` whether this call read it.
    """

    time: FloatArray
    torsion_moment: FloatArray
    angular_acceleration: FloatArray
    speed: FloatArray
    fs: float
    spec: ScenarioSpec
    truth: Truth
    user_rig: dict[str, float]
    labels: dict[str, str]
    stick: BoolArray
    gen_seconds: float = math.nan
    from_cache: bool = False

    def write_csv(self, path: str | Path) -> Path:
        """Write the measured record as a rig CSV (``#`` comment lines, then 4 columns).

        Parameters
        ----------
        path : str or Path
            Output file.

        Returns
        -------
        Path
            The file written.

        Raises
        ------
        OutputError
            If the file cannot be written.
        """
        p = Path(path)
        header = (
            f'# source: tribo_scenarios {self.spec.version}, seed {self.spec.seed}\n'
            '# units: s, N m, rad/s^2, rad/s\n'
            'time,torsion_moment,angular_acceleration,speed'
        )
        data = np.column_stack((self.time, self.torsion_moment, self.angular_acceleration,
                                self.speed))  # fmt: skip
        try:
            np.savetxt(p, data, fmt=['%.9f', '%.9g', '%.9g', '%.9g'], delimiter=',',
                       header=header, comments='')  # fmt: skip
        except OSError as exc:
            raise OutputError(f'{p}: cannot write the record: {exc.strerror or exc}') from exc
        return p

    def write_rig_yaml(self, path: str | Path) -> Path:
        """Write the user's RIG.yaml (keys and units of ``config/rig.yaml``).

        Parameters
        ----------
        path : str or Path
            Output file.

        Returns
        -------
        Path
            The file written.

        Raises
        ------
        OutputError
            If the file cannot be written.
        """
        p = Path(path)
        lines = [f'# RIG.yaml a lab would pass for tribo_scenarios seed {self.spec.seed} (SI)']
        for key, unit in RIG_KEYS:
            if key in self.user_rig:
                lines.append(f'{key}: {self.user_rig[key]!r}    # [{unit}]')
        try:
            p.write_text('\n'.join(lines) + '\n')
        except OSError as exc:
            raise OutputError(f'{p}: cannot write the rig config: {exc.strerror or exc}') from exc
        return p

    def write_truth_json(self, path: str | Path) -> Path:
        """Write the truth, the labels and the whole specification as JSON.

        Parameters
        ----------
        path : str or Path
            Output file.

        Returns
        -------
        Path
            The file written.

        Raises
        ------
        OutputError
            If the file cannot be written.
        """
        p = Path(path)
        doc = {
            'truth': asdict(self.truth),
            'labels': self.labels,
            'user_rig': self.user_rig,
            'gen_seconds': self.gen_seconds,
            'spec': self.spec.as_dict(),
        }
        try:
            p.write_text(json.dumps(doc, indent=2, default=str) + '\n')
        except OSError as exc:
            raise OutputError(f'{p}: cannot write the truth: {exc.strerror or exc}') from exc
        return p

    def write_dir(self, directory: str | Path) -> tuple[Path, Path, Path]:
        """Write ``record.csv``, ``rig.yaml`` and ``truth.json`` into a directory.

        Parameters
        ----------
        directory : str or Path
            Output directory (made if missing).

        Returns
        -------
        tuple of Path
            The CSV, the RIG.yaml and the truth file.

        Raises
        ------
        OutputError
            If the directory or a file cannot be written.
        """
        d = Path(directory)
        try:
            d.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OutputError(f'{d}: cannot make the directory: {exc.strerror or exc}') from exc
        return (
            self.write_csv(d / 'record.csv'),
            self.write_rig_yaml(d / 'rig.yaml'),
            self.write_truth_json(d / 'truth.json'),
        )
