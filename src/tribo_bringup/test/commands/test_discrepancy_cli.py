"""``tribo discrepancy`` end to end on a rig CSV, the report layout and bad input.

The CSV is written by ``tribo simulate`` from config/rig_hidden_frictional_lag.yaml (a
hidden first-order lag of the friction coefficient, tau = 2 ms, at 30 rpm; 3 s at 5 kHz
with the noise of the rig file); the command must name the family, write discrepancy.json with
the documented keys (core/discrepancy/report.py) and the plots.
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
#: The hidden lag [s] (config/rig_hidden_frictional_lag.yaml).
LAG = 2e-3
#: Sample rate of the simulated records [Hz].
FS = 5000.0
#: A model that explains the record leaves its torque residual within this factor of the
#: white noise floor (the segments restart from measured, noisy states: about 1.05) [-].
FLOOR_FACTOR = 1.3


def _simulate(out: Path, seed: int) -> Path:
    rc = main(['simulate', '--rig', str(CONFIG / 'rig_hidden_frictional_lag.yaml'),
               '--duration', '3', '--fs', str(FS), '--noise', '--seed', str(seed),
               '--out', str(out)])  # fmt: skip
    assert rc == 0
    return out


@pytest.fixture(scope='module')
def hidden_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _simulate(tmp_path_factory.mktemp('disc') / 'hidden.csv', 3)


@pytest.mark.slow
def test_cli_names_the_hidden_effect_and_writes_the_report(
    hidden_csv: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / 'report'
    # the two families that one constant speed could confuse (the full library's decisions
    # are tested in tribo_estimation's test_pipeline.py)
    rc = main(['discrepancy', str(hidden_csv), '--rig', str(CONFIG / 'rig.yaml'), '--out',
               str(out), '--candidates', 'frictional_lag,stribeck_shape'])  # fmt: skip
    assert rc == 0
    data = json.loads((out / 'discrepancy.json').read_text())
    assert {'verdict', 'finding', 'reason', 'experiment', 'added', 'cannot_tell_apart',
            'partial', 'baseline', 'final', 'noise_floor', 'unexplained', 'instrument',
            'drive', 'records', 'rounds', 'settings'} <= set(data)  # fmt: skip
    assert data['verdict'] == 'named', data['finding']
    assert [a['family'] for a in data['added']] == ['frictional_lag']
    first = data['added'][0]
    assert set(first) >= {'family', 'form', 'effect', 'params', 'se', 'units', 'rms',
                          'statistic', 'explained', 'failing', 'at_bound'}  # fmt: skip
    assert first['form'] == first['effect'] == 'frictional_lag'
    # within 20 % of the hidden 2 ms (the parameter tolerance)
    assert first['params']['lag_tau'] == pytest.approx(LAG, rel=0.2)
    # the named model explains the record: down to the floor, and within its null law
    assert data['final']['rms'] <= 0.5 * data['baseline']['rms']
    assert data['final']['rms'] < FLOOR_FACTOR * data['noise_floor']
    assert first['rms'][0] == pytest.approx(data['final']['rms'], rel=1e-9)
    null = data['records'][0]['null']
    assert first['statistic'][0] <= null['torsion_moment']['bound']
    assert first['explained'] >= 0.9 and first['failing'] == [] and first['at_bound'] == []
    assert data['cannot_tell_apart'] == [] and data['unexplained'] == []
    assert all(
        isinstance(v, float) and math.isfinite(v)
        for v in (data['baseline']['rms'], data['final']['rms'])
    )
    for png in ('traces.png', 'spectrum.png', 'residual_phase.png'):
        assert (out / png).stat().st_size > 1000, png
    captured = capsys.readouterr()
    assert '[discrepancy] round 1' in captured.err  # progress on stderr
    assert captured.out.startswith('found frictional_lag (lag_tau = ')


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
    fs = FS
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
    rc = main(['discrepancy', str(bag), '--rig', str(CONFIG / 'rig.yaml'), '--out', str(out),
               '--candidates', 'frictional_lag,viscous_friction', '--max-effects', '1',
               '--no-plots'])  # fmt: skip
    assert rc == 0
    data = json.loads((out / 'discrepancy.json').read_text())
    assert data['verdict'] == 'named', data['finding']
    assert [a['family'] for a in data['added']] == ['frictional_lag']
    assert data['added'][0]['params']['lag_tau'] == pytest.approx(LAG, rel=0.2)
    # only the families asked for were screened
    screened = {e['family'] for rnd in data['rounds'] for e in rnd}
    assert screened <= {'frictional_lag', 'viscous_friction'}
    assert data['settings']['families'] == ['frictional_lag', 'viscous_friction']


@pytest.mark.slow
def test_cli_fits_several_records_jointly(
    hidden_csv: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Two records of one rig (another noise seed): one verdict for both, the effect shared,
    and per record its friction law, its null law and what remains."""
    second = _simulate(tmp_path / 'second.csv', 4)
    capsys.readouterr()  # the simulation's own output
    out = tmp_path / 'joint'
    rc = main(['discrepancy', str(hidden_csv), str(second), '--rig', str(CONFIG / 'rig.yaml'),
               '--out', str(out), '--candidates', 'frictional_lag,viscous_friction'])  # fmt: skip
    assert rc == 0
    data = json.loads((out / 'discrepancy.json').read_text())
    assert data['settings']['records'] == 2 and len(data['records']) == 2
    assert data['sources'] == [str(hidden_csv), str(second)]
    assert data['verdict'] == 'named', data['finding']
    (lag,) = data['added']
    assert lag['family'] == 'frictional_lag'
    assert lag['params']['lag_tau'] == pytest.approx(LAG, rel=0.2)
    # the shared effect: one residual rms and one statistic per record, each within that
    # record's null law
    assert len(lag['rms']) == len(lag['statistic']) == 2
    for rep, rms, stat in zip(data['records'], lag['rms'], lag['statistic'], strict=True):
        assert {'baseline', 'final', 'noise_floor', 'null', 'instrument', 'drive',
                'unexplained'} <= set(rep)  # fmt: skip
        assert rms == pytest.approx(rep['final']['rms'], rel=1e-9)
        assert rms < FLOOR_FACTOR * rep['noise_floor']
        assert stat <= rep['null']['torsion_moment']['bound']
        assert rep['final']['params']['mu0'] == pytest.approx(0.13, rel=0.05)
    # the one-line finding names the family and gives each record's rms before -> after
    line = capsys.readouterr().out
    assert line.startswith('found frictional_lag') and line.count('->') == 2
