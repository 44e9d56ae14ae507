"""Tests of `tribo simulate` and `tribo decay` through the CLI dispatcher."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from tribo_bringup.cli import main
from tribo_estimation.core.rigio import read_rig_csv

REPO = Path(__file__).resolve().parents[4]


def test_simulate_then_decay(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    csv = tmp_path / 'decay.csv'
    rc = main(
        [
            'simulate',
            '--rig',
            str(REPO / 'config' / 'rig_decay_example.yaml'),
            '--free-decay',
            '--phi0',
            '0.01',
            '--duration',
            '1.5',
            '--noise',
            '--seed',
            '3',
            '--out',
            str(csv),
        ]
    )
    assert rc == 0
    rec = read_rig_csv(csv)
    assert len(rec) == 15000
    out = tmp_path / 'res'
    assert main(['decay', str(csv), '--out', str(out)]) == 0
    res = json.loads((out / 'decay.json').read_text())
    for key in ('I1', 'K1', 'C1', 'f_n_hz', 'zeta', 'I1_se', 'K1_se', 'C1_se', 'zeta_se'):
        assert key in res
    # rig_decay_example.yaml: I1 = 0.0152, C1 = 1850, K1 = 0.09 (issue tolerances)
    assert res['I1'] == pytest.approx(0.0152, rel=0.01)
    assert res['C1'] == pytest.approx(1850.0, rel=0.01)
    assert res['K1'] == pytest.approx(0.09, rel=0.1)


def test_simulate_stick_slip_csv(tmp_path: Path) -> None:
    csv = tmp_path / 'rig.csv'
    assert (
        main(
            [
                'simulate',
                '--rig',
                str(REPO / 'config' / 'rig.yaml'),
                '--duration',
                '1.2',
                '--fs',
                '5000',
                '--out',
                str(csv),
            ]
        )
        == 0
    )
    rec = read_rig_csv(csv)
    assert len(rec) == 6000
    assert rec.sample_rate == pytest.approx(5000.0, rel=1e-9)
    assert set(rec.extra) == {'friction_moment', 'slip_speed', 'stick'}
    assert rec.extra['stick'][3000:].mean() > 0.1  # stick-slip after the ramp
    assert np.all(np.diff(rec.time) > 0)
    assert rec.metadata['C1'] == '2338.6'


def test_bad_input_exit_code_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / 'bad.csv'
    bad.write_text('time,torsion_moment,speed\n0,1,2\n')
    assert main(['decay', str(bad), '--out', str(tmp_path / 'o')]) == 2
    err = capsys.readouterr().err
    assert 'angular_acceleration' in err and len(err.strip().splitlines()) == 1
    cfg = tmp_path / 'rig.yaml'
    cfg.write_text('I1: 0.01\n')
    assert (
        main(['simulate', '--rig', str(cfg), '--duration', '1', '--out', str(tmp_path / 'x.csv')])
        == 2
    )
    assert "missing key 'K1'" in capsys.readouterr().err
    # a stick-slip record is no free decay
    csv = tmp_path / 'ss.csv'
    main(
        [
            'simulate',
            '--rig',
            str(REPO / 'config' / 'rig.yaml'),
            '--duration',
            '1',
            '--out',
            str(csv),
        ]
    )
    capsys.readouterr()
    assert main(['decay', str(csv), '--out', str(tmp_path / 'd')]) == 2
