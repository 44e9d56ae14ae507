"""Tests of rig CSV reading/writing and the RIG.yaml loader."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tribo_estimation.core.config import load_rig_config, rig_config_from_dict
from tribo_estimation.core.model import DriveProfile, FrictionLaw, RigParams
from tribo_estimation.core.rigio import iter_rig_csv, read_rig_csv, write_rig_csv
from tribo_estimation.core.simulate import simulate
from tribo_estimation.errors import (
    ConfigFileError,
    InvalidDataError,
    InvalidParameterError,
    MissingColumnError,
    MissingKeyError,
    NonMonotonicTimeError,
    TooShortError,
    UnitError,
)

REPO = Path(__file__).resolve().parents[4]
HEADER = 'time,torsion_moment,angular_acceleration,speed'


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / 'rig.csv'
    p.write_text(text)
    return p


def test_roundtrip_with_truth_columns_and_metadata(tmp_path: Path) -> None:
    r = simulate(RigParams.tab1(), FrictionLaw(0.13, 0.1), DriveProfile(2.0), 0.25)
    p = tmp_path / 'sim.csv'
    write_rig_csv(
        p,
        r.time,
        r.torsion_moment,
        r.angular_acceleration,
        r.speed,
        extra={'friction_moment': r.friction_moment, 'stick': r.stick.astype(float)},
        metadata={'I1': 0.0109, 'note': 'test'},
    )
    rec = read_rig_csv(p)
    # 9 significant digits in the file (12 for time)
    np.testing.assert_allclose(rec.time, r.time, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(rec.torsion_moment, r.torsion_moment, rtol=1e-8)
    np.testing.assert_allclose(
        rec.angular_acceleration, r.angular_acceleration, rtol=1e-8, atol=1e-9
    )
    np.testing.assert_array_equal(rec.extra['stick'] > 0.5, r.stick)
    assert rec.metadata['I1'] == '0.0109' and rec.metadata['note'] == 'test'
    assert rec.sample_rate == pytest.approx(10_000.0, rel=1e-9)


def test_chunked_reading_equals_whole(tmp_path: Path) -> None:
    r = simulate(RigParams.tab1(), FrictionLaw(0.13, 0.1), DriveProfile(2.0), 0.2)
    p = tmp_path / 'sim.csv'
    write_rig_csv(p, r.time, r.torsion_moment, r.angular_acceleration, r.speed)
    blocks = list(iter_rig_csv(p, block_size=333))
    assert len(blocks) == -(-2000 // 333)
    assert all(len(b) == 333 for b in blocks[:-1])
    whole = read_rig_csv(p)
    np.testing.assert_array_equal(np.concatenate([b.time for b in blocks]), whole.time)
    np.testing.assert_array_equal(
        np.concatenate([b.torsion_moment for b in blocks]), whole.torsion_moment
    )


def test_comments_and_blank_lines_skipped(tmp_path: Path) -> None:
    p = _write(tmp_path, f'# rig: test\n\n{HEADER}\n0,1,2,3\n# mid comment\n\n1e-4,1,2,3\n')
    rec = read_rig_csv(p)
    assert len(rec) == 2 and rec.metadata == {'rig': 'test'}
    assert rec.first_line == 4


def test_missing_column_named(tmp_path: Path) -> None:
    p = _write(tmp_path, 'time,torsion_moment,speed\n0,1,2\n')
    with pytest.raises(MissingColumnError, match='angular_acceleration'):
        read_rig_csv(p)


def test_nan_names_line_and_column(tmp_path: Path) -> None:
    p = _write(tmp_path, f'{HEADER}\n0,1,2,3\n1e-4,nan,2,3\n')
    with pytest.raises(InvalidDataError, match=r"line 3, column 'torsion_moment'"):
        read_rig_csv(p)
    p = _write(tmp_path, f'{HEADER}\n0,1,2,3\n1e-4,1,inf,3\n')
    with pytest.raises(InvalidDataError, match='angular_acceleration'):
        read_rig_csv(p)


def test_text_cell_and_wrong_field_count(tmp_path: Path) -> None:
    p = _write(tmp_path, f'{HEADER}\n0,1,2,3\n1e-4,1,abc,3\n')
    with pytest.raises(InvalidDataError, match=r"line 3, column 'angular_acceleration'"):
        read_rig_csv(p)
    p = _write(tmp_path, f'{HEADER}\n0,1,2,3\n1e-4,1,2\n')
    with pytest.raises(InvalidDataError, match='line 3 has 3 fields'):
        read_rig_csv(p)


def test_non_monotonic_time_within_and_across_blocks(tmp_path: Path) -> None:
    p = _write(tmp_path, f'{HEADER}\n0,1,2,3\n2e-4,1,2,3\n1e-4,1,2,3\n')
    with pytest.raises(NonMonotonicTimeError, match='line 4'):
        read_rig_csv(p)
    with pytest.raises(NonMonotonicTimeError, match='line 4'):
        list(iter_rig_csv(p, block_size=2))


def test_speed_in_rpm_spotted(tmp_path: Path) -> None:
    p = _write(tmp_path, f'{HEADER}\n0,1,2,3\n1e-4,1,2,600\n')
    with pytest.raises(UnitError, match='rpm'):
        read_rig_csv(p)
    assert len(read_rig_csv(p, max_speed=None)) == 2


def test_empty_and_headerless(tmp_path: Path) -> None:
    with pytest.raises(TooShortError):
        read_rig_csv(_write(tmp_path, f'# only a comment\n{HEADER}\n'))
    with pytest.raises(TooShortError):
        read_rig_csv(_write(tmp_path, '# nothing\n'))
    with pytest.raises(InvalidDataError):
        read_rig_csv(tmp_path / 'missing.csv')


# ------------------------------------------------------------------------- RIG.yaml
def test_shipped_rig_yaml_loads_and_shows_stick_slip() -> None:
    cfg = load_rig_config(REPO / 'config' / 'rig.yaml')
    assert cfg.rig.natural_frequency_hz == pytest.approx(73.7, abs=0.05)
    for rpm in (10, 30, 60):
        r = simulate(cfg.rig, cfg.friction, DriveProfile(rpm * np.pi / 30), 0.4)
        # clear stick-slip: sticks make up a sizeable fraction of the time
        assert 0.1 < r.stick[1000:].mean() < 0.9, rpm
    assert cfg.noise.torque == 0.05 and cfg.noise.accel == 2.0
    assert cfg.extensions.is_baseline


def _base() -> dict[str, object]:
    return {
        'I1': 0.0109,
        'K1': 0.04034,
        'C1': 2338.6,
        'I2': 0.0315,
        'K2': 4.0,
        'C2': 5975.0,
        'F_N': 8000.0,
        'R': 0.08,
        'mu0': 0.13,
        'mu_inf': 0.10,
        'k': 2.0,
        'nominal_speed': 3.0,
    }


def test_config_missing_key_named() -> None:
    d = _base()
    del d['C2']
    with pytest.raises(MissingKeyError, match="'C2'"):
        rig_config_from_dict(d, 'x.yaml')


def test_config_bad_values_named() -> None:
    with pytest.raises(InvalidParameterError, match="'I1'"):
        rig_config_from_dict({**_base(), 'I1': -0.01})
    with pytest.raises(InvalidParameterError, match='rpm'):
        rig_config_from_dict({**_base(), 'nominal_speed': 3000.0})
    with pytest.raises(InvalidParameterError, match="'mu0'"):
        rig_config_from_dict({**_base(), 'mu0': 'high'})
    with pytest.raises(InvalidParameterError, match='unknown key'):
        rig_config_from_dict({**_base(), 'I3': 1.0})
    with pytest.raises(InvalidParameterError, match='unknown effect'):
        rig_config_from_dict({**_base(), 'effects': {'warp': 1.0}})
    cfg = rig_config_from_dict({**_base(), 'effects': {'lag_tau': 0.001}})
    assert cfg.extensions.lag_tau == 0.001


def test_config_file_errors(tmp_path: Path) -> None:
    with pytest.raises(ConfigFileError):
        load_rig_config(tmp_path / 'none.yaml')
    bad = tmp_path / 'bad.yaml'
    bad.write_text('I1: [unclosed\n')
    with pytest.raises(ConfigFileError, match=r'bad\.yaml'):
        load_rig_config(bad)
