"""Bad input never hangs and never lies: one test per rule (units, spikes, time bases,
atomic outputs, YAML, one line and exit 2, bugs shown, Ctrl-C)."""

from __future__ import annotations

import csv
import math
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pytest
from support import ROOT
from test_fuzz_commands import base_record, tribo

if TYPE_CHECKING:
    from tribo_estimation.core.simulate import SimResult

RIG = ROOT / 'config' / 'rig.yaml'
NVCT = ROOT / 'config' / 'nvct.yaml'


def _write(path: Path, cols: list[np.ndarray]) -> Path:
    from tribo_estimation.core.rigio import write_rig_csv

    write_rig_csv(path, *cols)
    return path


def _blocks(out: Path) -> list[dict[str, str]]:
    with (out / 'blocks.csv').open() as fh:
        return list(csv.DictReader(fh))


@pytest.fixture(scope='module')
def record(sim_record: Callable[..., SimResult]) -> list[np.ndarray]:
    """3.2 s of the shipped rig at 2 kHz with noise (three whole 1 s blocks)."""
    r = sim_record(3.2, 2000.0, seed=7)
    return [r.time, r.torsion_moment, r.angular_acceleration, r.speed]


# ----------------------------------------------------------------------------- YAML
def test_rig_yaml_1e5_is_a_number_out_of_range(tmp_path: Path) -> None:
    from tribo_estimation.core.config import load_rig_config
    from tribo_estimation.errors import InvalidParameterError

    p = tmp_path / 'rig.yaml'
    p.write_text(RIG.read_text().replace('mu0: 0.13', 'mu0: 1e5'))
    with pytest.raises(InvalidParameterError, match=r"'mu0' = 100000.0 outside the plausible"):
        load_rig_config(p)
    p.write_text(RIG.read_text() + 'C1: 2000.0\n')
    with pytest.raises(Exception, match="duplicate key 'C1'"):
        load_rig_config(p)


@pytest.mark.parametrize(
    ('line', 'message'),
    [
        ('k_det_rel_sd: 0.1', "unknown key 'k_det_rel_sd' (did you mean 'k_det_rel_se'?)"),
        ('load_N: 1e308', 'load_N = 1e+308 exceeds the plausible maximum'),
    ],
)
def test_wear_refuses_bad_nvct_keys(tmp_path: Path, line: str, message: str) -> None:
    cfg = tmp_path / 'nvct.yaml'
    text = NVCT.read_text().replace('depth_profile: depth_profile.csv', '')
    text = text.replace('load_N: 100.0', '')
    extra = '' if line.startswith('load_N') else 'load_N: 100.0\n'
    cfg.write_text(
        f'{text}\ndepth_profile: {ROOT / "config" / "depth_profile.csv"}\n{extra}{line}\n'
    )
    counts = tmp_path / 'c.csv'
    counts.write_text('t_start,t_end,counts,live_time\n0,60,100,59.9\n')
    r = tribo('wear', str(counts), '--nvct', str(cfg), '--out', str(tmp_path / 'o'))
    assert r.rc == 2 and message in r.stderr, r.stderr
    assert not (tmp_path / 'o').exists()


# ----------------------------------------------------------------------------- plausibility
def test_unit_errors_are_named(tmp_path: Path, record: list[np.ndarray]) -> None:
    t, tq, ac, sp = record
    cases = {
        'torsion_moment looks like N mm': [t, tq * 1000.0, ac, sp],
        'speed looks like rpm': [t, tq, ac, sp * 30.0 / math.pi],
        'deg/s^2': [t, tq, ac * 180.0 / math.pi, sp],
        'the time column looks like ms': [t * 1000.0, tq, ac, sp],
    }
    for message, cols in cases.items():
        out = tmp_path / 'o'
        r = tribo('friction', str(_write(tmp_path / 'r.csv', cols)), '--rig', str(RIG),
                  '--out', str(out), '--no-plots', '--quiet')  # fmt: skip
        assert r.rc == 2 and message in r.stderr.splitlines()[-1], (message, r.stderr)
        assert not out.exists()  # nothing new in --out


def test_speed_at_rest_error_for_discrepancy_warning_for_friction(
    tmp_path: Path, record: list[np.ndarray]
) -> None:
    t, tq, ac, sp = record
    p = _write(tmp_path / 'r.csv', [t, tq, ac, sp * 0.001])
    r = tribo('discrepancy', str(p), '--rig', str(RIG), '--out', str(tmp_path / 'd'))
    assert r.rc == 2 and 'a free-decay record?' in r.stderr.splitlines()[-1], r.stderr
    r = tribo('friction', str(p), '--rig', str(RIG), '--out', str(tmp_path / 'f'), '--quiet',
              '--no-plots')  # fmt: skip
    assert r.rc == 0 and 'warning' in r.stderr and 'at rest at the start' in r.stderr, r.stderr


def test_drive_speed_mismatch_is_a_warning(record: list[np.ndarray]) -> None:
    """A record at 6.28 rad/s analysed with a RIG.yaml saying 3.14: the measured drive
    profile (core.drive, used by both fits) says so once; the plausibility check
    leaves the drive speed to it."""
    from tribo_estimation.core.config import load_rig_config
    from tribo_estimation.core.drive import estimate_drive
    from tribo_estimation.core.plausibility import Scales, check_channels

    cfg = load_rig_config(RIG)
    sc = Scales.of(cfg.rig, cfg.friction, cfg.drive.nominal_speed)
    t, tq, ac, sp = record
    assert check_channels(tq, ac, sp, sc, 'r') == []
    assert check_channels(tq, ac, sp * 2.0, sc, 'r') == []  # not an input error
    est = estimate_drive(t, sp * 2.0, cfg.drive.nominal_speed)
    assert est.mismatched and est.mismatch == pytest.approx(1.0, abs=0.02)  # +100 % (2 %)
    assert 'nominal_speed' in (est.warning() or '')
    assert not estimate_drive(t, sp, cfg.drive.nominal_speed).mismatched


def test_spikes_found_without_false_alarms(record: list[np.ndarray]) -> None:
    from tribo_estimation.core.config import load_rig_config
    from tribo_estimation.core.plausibility import Scales, find_spikes

    cfg = load_rig_config(RIG)
    sc = Scales.of(cfg.rig, cfg.friction, cfg.drive.nominal_speed)
    _, tq, ac, sp = record
    for x, s in ((tq, sc.torque), (ac, sc.accel), (sp, sc.speed)):
        assert not find_spikes(x, s).any()  # clean stick-slip: no spike
    bad = tq.copy()
    bad[[100, 2500, 2501]] = [1e12, 1e8, -1e8]
    assert list(np.flatnonzero(find_spikes(bad, sc.torque))) == [100, 2500, 2501]


def test_a_spike_changes_only_its_own_block(tmp_path: Path, record: list[np.ndarray]) -> None:
    t, tq, ac, sp = record
    spiked = tq.copy()
    spiked[int(1.5 * 2000)] = 1e12  # in block 1
    rows = {}
    for name, col in (('clean', tq), ('spike', spiked)):
        out = tmp_path / name
        r = tribo('friction', str(_write(tmp_path / f'{name}.csv', [t, col, ac, sp])), '--rig',
                  str(RIG), '--out', str(out), '--no-plots', '--quiet')  # fmt: skip
        assert r.rc == 0, r.stderr
        rows[name] = _blocks(out)
    clean, spike = rows['clean'], rows['spike']
    assert [r['spikes'] for r in spike] == ['0', '1', '0', '0']
    assert spike[1]['quality'] == 'spikes' and clean[1]['quality'] == 'ok'
    for i in (0, 2):  # neighbours untouched (bit-identical)
        assert spike[i]['mu0'] == clean[i]['mu0'] and spike[i]['mu_inf'] == clean[i]['mu_inf']
    # its own block: the repaired sample leaves mu0 within 1e-3 of the clean fit
    assert abs(float(spike[1]['mu0']) - float(clean[1]['mu0'])) < 1e-3


# ----------------------------------------------------------------------------- time bases
def test_epoch_stamps_give_distinct_blocks(tmp_path: Path, record: list[np.ndarray]) -> None:
    t, tq, ac, sp = record
    out = tmp_path / 'o'
    r = tribo('friction', str(_write(tmp_path / 'e.csv', [t + 1.79546274e9, tq, ac, sp])),
              '--rig', str(RIG), '--out', str(out), '--no-plots', '--quiet')  # fmt: skip
    assert r.rc == 0, r.stderr
    rows = _blocks(out)
    starts = [float(r['t_start']) for r in rows]
    assert starts[:3] == [1.79546274e9, 1.79546274e9 + 1.0, 1.79546274e9 + 2.0]
    assert [r['quality'] for r in rows[1:3]] == ['ok', 'ok']


def test_jitter_resampled_irregular_named(tmp_path: Path, record: list[np.ndarray]) -> None:
    from tribo_estimation.core.inputs import record_from_arrays
    from tribo_estimation.errors import IrregularSamplingError

    t, tq, ac, sp = record
    jit = t + np.random.default_rng(3).uniform(-5e-6, 5e-6, t.size)  # +-1 % at 2 kHz
    rec = record_from_arrays(jit, tq, ac, sp, source='r')
    assert rec.fs == 2000.0 and 0.005 < rec.findings.max_jitter <= 0.0101
    np.testing.assert_allclose(rec.time, np.arange(t.size) / 2000.0, rtol=0, atol=1e-12)
    out = tmp_path / 'o'
    r = tribo('friction', str(_write(tmp_path / 'j.csv', [jit, tq, ac, sp])), '--rig',
              str(RIG), '--out', str(out), '--no-plots', '--quiet')  # fmt: skip
    assert r.rc == 0 and _blocks(out)[1]['quality'] == 'ok', r.stderr
    bad = t.copy()
    bad[1000] += 0.4 / 2000.0
    with pytest.raises(IrregularSamplingError, match=r'sample 1001, time 0.5002 s is \+0.40'):
        record_from_arrays(bad, tq, ac, sp, source='r')


def test_decay_time_in_ms_is_named(tmp_path: Path) -> None:
    decay_rig = str(ROOT / 'config' / 'rig_decay_example.yaml')
    r = tribo('simulate', '--rig', decay_rig, '--free-decay', '--duration', '1', '--fs', '2000',
              '--out', str(tmp_path / 'd.csv'))  # fmt: skip
    assert r.rc == 0, r.stderr
    from tribo_estimation.core.rigio import read_rig_csv

    d = read_rig_csv(tmp_path / 'd.csv')
    p = _write(tmp_path / 'ms.csv', [d.time * 1e3, d.torsion_moment, d.angular_acceleration,
                                      d.speed])  # fmt: skip
    r = tribo('decay', str(p), '--out', str(tmp_path / 'o'))
    assert r.rc == 2 and 'time column looks like ms' in r.stderr, r.stderr


# ----------------------------------------------------------------------------- CLI
def test_simulate_absurd_duration_is_one_line(tmp_path: Path) -> None:
    out = tmp_path / 'x.csv'
    r = tribo('simulate', '--rig', str(RIG), '--duration', '1e308', '--out', str(out))
    assert r.rc == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert 'outside (0, 86400] s' in r.stderr and not out.exists()


def test_a_bug_shows_its_traceback(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    import tribo_estimation.core.config as config

    def boom(path: object) -> None:
        raise ZeroDivisionError('a programming error')

    monkeypatch.setattr(config, 'load_rig_config', boom)
    r = tribo('simulate', '--rig', str(RIG), '--duration', '1', '--out', str(tmp_path / 'x.csv'))
    assert r.rc == 1
    assert 'Traceback' in r.stderr and 'ZeroDivisionError' in r.stderr
    assert 'please report it' in r.stderr.splitlines()[-1]


def test_ctrl_c_exits_130_without_partial_output(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    import tribo_estimation.core.simulate as sim

    real = sim.simulate
    calls = []

    def interrupted(*args: object, **kw: object) -> object:
        calls.append(1)
        if len(calls) == 2:  # after one chunk was written
            raise KeyboardInterrupt
        return real(*args, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(sim, 'simulate', interrupted)
    out = tmp_path / 'x.csv'
    r = tribo('simulate', '--rig', str(RIG), '--duration', '3', '--fs', '1000', '--out', str(out))
    assert r.rc == 130 and len(calls) == 2
    assert list(tmp_path.iterdir()) == []  # no file, no staging leftovers


def test_failing_friction_leaves_no_blocks(tmp_path: Path) -> None:
    t, tq, ac, sp = base_record()
    out = tmp_path / 'o'
    r = tribo('friction', str(_write(tmp_path / 'r.csv', [t, tq * 1e3, ac, sp])), '--rig',
              str(RIG), '--out', str(out), '--quiet')  # fmt: skip
    assert r.rc == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ['r.csv']


def test_undecodable_csv_names_the_file(tmp_path: Path) -> None:
    p = tmp_path / 'r.csv'
    p.write_bytes(b'time,torsion_moment,angular_acceleration,speed\n0,\xff\xfe,1,2\n')
    r = tribo('friction', str(p), '--rig', str(RIG), '--out', str(tmp_path / 'o'))
    assert r.rc == 2 and f'{p}: not a UTF-8 text rig CSV' in r.stderr, r.stderr


def test_wear_simulate_refuses_absurd_durations(tmp_path: Path) -> None:
    sim = tmp_path / 'sim.yaml'
    sim.write_text(
        f'nvct_config: {NVCT}\nduration_min: 1e308\ntrue_wear: {{running_in_volume_um3: 1, '
        'running_in_tau_min: 1, progressive_rate_um3_per_min: 1}\n'
    )
    out = tmp_path / 'c.csv'
    r = tribo('wear', '--simulate', str(out), '--sim', str(sim))
    assert r.rc == 2 and 'at most 1e+06 dwells' in r.stderr and not out.exists(), r.stderr


def test_days_since_reference_beyond_60_half_lives_refused(tmp_path: Path) -> None:
    from tribo_common.yamlio import load_yaml
    from tribo_nvct.core.config import config_from_dict
    from tribo_nvct.errors import NvctConfigError

    raw = load_yaml(NVCT, NvctConfigError)
    raw['days_since_reference'] = 1e5  # 1300 half-lives of Co-56: exp() overflowed
    with pytest.raises(NvctConfigError, match='more than 60 half-lives of Co-56'):
        config_from_dict(raw, NVCT.parent, 'nvct.yaml')


def test_tiny_nvct_values_refused(tmp_path: Path) -> None:
    from tribo_common.yamlio import load_yaml
    from tribo_nvct.core.config import config_from_dict
    from tribo_nvct.errors import NvctConfigError

    raw = load_yaml(NVCT, NvctConfigError)
    raw['stroke_m'] = 6e-261  # with frequency_hz 6e-261: sliding distance underflowed to 0
    with pytest.raises(NvctConfigError, match='stroke_m = 6e-261 is implausibly small'):
        config_from_dict(raw, NVCT.parent, 'nvct.yaml')
