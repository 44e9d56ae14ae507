"""``tribo discrepancy`` end to end on a rig CSV, the report layout and bad input.

The CSV is written by ``tribo simulate`` from config/rig_hidden_torque_sensor_lag.yaml
(a hidden first-order lag of the torsion amplifier, tau = 0.5 ms; run with
``--no-torsion-lag``, else the instrument model takes it out before any effect); the command
must name it, write discrepancy.json with the documented keys and the plots.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip('tribo_bringup')
from tribo_bringup.cli import main

CONFIG = Path(__file__).resolve().parents[4] / 'config'


@pytest.fixture(scope='module')
def hidden_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp('disc') / 'hidden.csv'
    rc = main(
        [
            'simulate',
            '--rig',
            str(CONFIG / 'rig_hidden_torque_sensor_lag.yaml'),
            '--duration',
            '1.2',
            '--noise',
            '--seed',
            '11',
            '--out',
            str(out),
        ]
    )
    assert rc == 0
    return out


@pytest.mark.slow
def test_cli_names_the_hidden_effect_and_writes_the_report(
    hidden_csv: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / 'report'
    rc = main(
        ['discrepancy', str(hidden_csv), '--rig', str(CONFIG / 'rig.yaml'), '--out', str(out),
         '--no-torsion-lag']
    )  # fmt: skip
    assert rc == 0
    data = json.loads((out / 'discrepancy.json').read_text())
    assert {'baseline', 'added', 'final', 'unexplained'} <= set(data)
    assert [a['effect'] for a in data['added']][:1] == ['torque_sensor_lag']
    first = data['added'][0]
    assert set(first) >= {'effect', 'params', 'rms_before', 'rms_after', 'delta_bic'}
    assert first['rms_before'] == pytest.approx(data['baseline']['rms'])
    assert data['final']['rms'] <= 0.5 * data['baseline']['rms']
    assert first['delta_bic'] < 0
    # within 20 % of the hidden 0.5 ms (the parameter tolerance)
    assert first['params']['torque_lag_tau'] == pytest.approx(5e-4, rel=0.2)
    assert all(
        isinstance(v, float) and math.isfinite(v)
        for v in (data['baseline']['rms'], data['final']['rms'])
    )
    for png in ('traces.png', 'spectrum.png', 'residual_breakaway.png'):
        assert (out / png).stat().st_size > 1000, png
    err = capsys.readouterr().err
    assert '[discrepancy] round 1' in err  # progress on stderr


def test_cli_rejects_bad_input(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rig = str(CONFIG / 'rig.yaml')
    assert main(['discrepancy', str(tmp_path / 'missing.csv'), '--rig', rig, '--out', 'x']) == 2
    assert 'no such file' in capsys.readouterr().err
    bad = tmp_path / 'bad.csv'
    bad.write_text('time,torsion_moment,angular_acceleration,speed\n0,1,nan,0\n0.0001,1,0,0\n')
    assert main(['discrepancy', str(bad), '--rig', rig, '--out', str(tmp_path / 'o')]) == 2
    assert 'error' in capsys.readouterr().err
    csv = tmp_path / 'short.csv'
    lines = ['time,torsion_moment,angular_acceleration,speed']
    lines += [f'{i * 1e-4:.4f},10.0,0.0,3.0' for i in range(500)]
    csv.write_text('\n'.join(lines) + '\n')
    rc = main(
        ['discrepancy', str(csv), '--rig', rig, '--out', str(tmp_path / 'o'), '--start', '1.0']
    )
    assert rc == 2
    assert 'holds' in capsys.readouterr().err
    # a record without stick phases cannot be segmented: a specific error, exit 2
    rc = main(['discrepancy', str(csv), '--rig', rig, '--out', str(tmp_path / 'o')])
    assert rc == 2
    assert 'stick phases' in capsys.readouterr().err
    rc = main(
        ['discrepancy', str(csv), '--rig', rig, '--out', str(tmp_path / 'o'), '--candidates', 'x']
    )
    assert rc == 2
    assert 'unknown effect' in capsys.readouterr().err


def test_cli_reads_a_bag(hidden_csv: Path, tmp_path: Path) -> None:
    """The same record as SampleBlock streams in an MCAP bag (blocks of 100 samples)."""
    bagio = pytest.importorskip('tribo_bringup.bagio')
    from tribo_estimation.core.rigio import read_rig_csv

    rec = read_rig_csv(hidden_csv)
    types = bagio.typestore().types
    fs = 10_000.0
    t0_ns = 1_700_000_000 * 1_000_000_000
    signals = {
        '/rig/torsion_moment': ('N m', rec.torsion_moment),
        '/rig/angular_acceleration': ('rad/s^2', rec.angular_acceleration),
        '/rig/speed': ('rad/s', rec.speed),
    }
    bag = tmp_path / 'bag'
    with bagio.BagWriter(bag) as w:
        for topic in signals:
            w.add_topic(topic, bagio.TOPIC_TYPES[topic])
        for first in range(0, len(rec), 100):
            stamp = t0_ns + round(first * 1e9 / fs)
            sec, nsec = divmod(stamp, 1_000_000_000)
            for topic, (unit, sig) in signals.items():
                header = types['std_msgs/msg/Header'](
                    stamp=types['builtin_interfaces/msg/Time'](sec=sec, nanosec=nsec),
                    frame_id=topic.split('/')[-1],
                )
                msg = types['tribo_msgs/msg/SampleBlock'](
                    header=header,
                    sample_rate=fs,
                    first_index=first,
                    unit=unit,
                    data=np.ascontiguousarray(sig[first : first + 100]),
                )
                w.write_msg(topic, stamp, msg)
    out = tmp_path / 'out'
    rc = main(
        [
            'discrepancy',
            str(bag),
            '--rig',
            str(CONFIG / 'rig.yaml'),
            '--out',
            str(out),
            '--candidates',
            'frictional_lag,torque_sensor_lag',
            '--max-effects',
            '1',
            '--no-plots',
            '--no-torsion-lag',
        ]
    )
    assert rc == 0
    data = json.loads((out / 'discrepancy.json').read_text())
    assert [a['effect'] for a in data['added']] == ['torque_sensor_lag']
    assert data['added'][0]['params']['torque_lag_tau'] == pytest.approx(5e-4, rel=0.2)


def test_cli_fits_several_records_jointly(
    hidden_csv: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Two records (here the same one twice, from 0.2 s and from 0.6 s): the joint report
    with per-record friction laws and an identifiability verdict per candidate."""
    out = tmp_path / 'joint'
    rc = main(['discrepancy', str(hidden_csv), str(hidden_csv), '--rig',
               str(CONFIG / 'rig.yaml'), '--out', str(out), '--start', '0.2',
               '--candidates', 'torque_sensor_lag,viscous_friction',
               '--no-torsion-lag'])  # fmt: skip
    assert rc == 0
    data = json.loads((out / 'discrepancy.json').read_text())
    assert data['joint'] is True and len(data['records']) == 2
    assert set(data['identifiable']) == {'torque_sensor_lag', 'viscous_friction'}
    for v in data['identifiable'].values():
        assert set(v) == {'ok', 'reason', 'suggest'}
    assert [a['effect'] for a in data['added']] == ['torque_sensor_lag']
    assert 'joint fit of 2 records' in capsys.readouterr().out
