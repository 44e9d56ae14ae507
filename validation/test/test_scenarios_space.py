"""The scenario space: reproducibility, coverage, the user's config, independence, files."""

from __future__ import annotations

import ast
import math
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
import yaml
from tribo_scenarios import (
    DRIVE_KINDS,
    LIBRARY_FORMS,
    OUTSIDE_FORMS,
    SAMPLE_RATES,
    InvalidRequestError,
    draw,
    generate,
)
from tribo_scenarios.__main__ import main
from tribo_scenarios.space import RPM

PKG = Path(__file__).resolve().parents[1] / 'tribo_scenarios'
SPEC_LABELS = {'rig', 'fs', 'drive', 'speed_lag', 'torque_lag', 'accel_lag', 'hum',
               'coloured_noise', 'spikes', 'torque_noise', 'config_shaft', 'config_k',
               'category', 'family', 'form', 'duration'}  # fmt: skip


@pytest.fixture(scope='module')
def specs():
    return [draw(s) for s in range(300)]


def test_same_seed_gives_identical_records(tmp_path):
    a = generate(draw(28), use_cache=False)
    b = generate(draw(28), cache_dir=tmp_path)  # simulated and written to the cache
    c = generate(draw(28), cache_dir=tmp_path)  # read back
    assert not b.from_cache and c.from_cache
    assert draw(28) == draw(28)
    for x in (b, c):
        for name in ('torsion_moment', 'angular_acceleration', 'speed', 'time'):
            assert np.array_equal(getattr(a, name), getattr(x, name)), name
        assert x.truth == a.truth and x.labels == a.labels
    assert (tmp_path / 'g1' / '28.npz').is_file()
    other = generate(draw(29), use_cache=False)
    assert other.torsion_moment.size != a.torsion_moment.size or not np.array_equal(
        other.torsion_moment, a.torsion_moment
    )


def test_fixing_one_part_keeps_the_others(tmp_path):
    base = draw(11)
    fixed = draw(11, family='out_of_library:c1_drift')
    assert fixed.rig == base.rig and fixed.instrument.speed == base.instrument.speed
    assert fixed.drive == base.drive and fixed.fs == base.fs
    assert fixed.effect.truth_name == 'out_of_library:c1_drift'
    assert fixed.cache_name() != base.cache_name() and base.cache_name() == '11.npz'


def test_the_space_covers_every_family_form_kind_and_rate(specs):
    forms = Counter((s.effect.name, s.effect.form) for s in specs)
    for fam, fs in LIBRARY_FORMS.items():
        for form in fs:
            assert forms[(fam, form)] >= 1, (fam, form)
    for name in OUTSIDE_FORMS:
        assert any(s.effect.name == name for s in specs), name
    assert {s.drive.kind for s in specs} == set(DRIVE_KINDS)
    assert {s.fs for s in specs} == set(SAMPLE_RATES)
    cats = Counter(s.effect.category for s in specs)
    # 25 / 60 / 15 % drawn: within 5 standard errors of 300 draws
    for cat, p in (('none', 0.25), ('library', 0.6), ('out_of_library', 0.15)):
        assert abs(cats[cat] / 300 - p) < 5 * math.sqrt(p * (1 - p) / 300), cat
    for s in specs:
        assert set(s.labels) == SPEC_LABELS and all(s.labels.values()), s.seed
        assert 4.0 <= s.duration <= 8.0
        assert 40.0 <= s.rig.f_chamber <= 150.0
        w = [t.delta for t in s.drive.transitions]
        assert min(np.cumsum(w)) >= -1e-12 and max(np.cumsum(w)) <= 80 * RPM * (1 + 1e-12)
    # the library's own form of each family is flagged (the bench checks its parameters)
    own = [s for s in specs if s.effect.own_form]
    assert {s.effect.form for s in own} <= {f[0] for f in LIBRARY_FORMS.values()}
    assert all(s.effect.form == LIBRARY_FORMS[s.effect.name][0] for s in own)


def test_the_user_config_differs_from_the_truth_as_documented(specs):
    keys = {'I1', 'K1', 'C1', 'I2', 'K2', 'C2', 'F_N', 'R', 'mu0', 'mu_inf', 'k',
            'nominal_speed'}  # fmt: skip
    n_off = 0
    for s in specs:
        u, r = s.user_rig, s.rig
        assert keys <= set(u)
        assert set(u) <= keys | {'ramp_time', 'noise_torque', 'noise_accel', 'noise_speed'}
        for key in ('I1', 'K1', 'C1', 'F_N', 'R'):
            assert abs(u[key] / getattr(r, key) - 1) <= 0.01 + 1e-12, (s.seed, key)
        errs = [abs(u[key] / getattr(r, key) - 1) for key in ('I2', 'K2', 'C2')]
        if s.labels['config_shaft'] == 'off':
            n_off += 1
            assert all(0.1 - 1e-12 <= e <= 0.25 + 1e-12 for e in errs), s.seed
        else:
            assert max(errs) <= 0.02 + 1e-12, s.seed
        if s.labels['config_k'] == 'preset':
            assert u['k'] == 2.0
        else:
            assert abs(u['k'] / r.k - 1) <= 0.05 + 1e-12
        assert 0 < u['mu_inf'] < u['mu0']
        assert ('ramp_time' in u) == (s.drive.ramp_time is not None)
        if s.drive.kind == 'constant':
            assert u['nominal_speed'] == pytest.approx(sum(t.delta for t in s.drive.transitions))
    assert 0.3 < n_off / len(specs) < 0.5


def test_effect_size_is_measured_against_the_record_without_it(tmp_path):
    ctrl = generate(draw(2), cache_dir=tmp_path)
    assert ctrl.truth.effect == 'none' and ctrl.truth.effect_snr == 0.0
    assert ctrl.labels['magnitude'] == 'none'
    eff = generate(draw(12), cache_dir=tmp_path)  # dwell-time stiction, clearly visible
    assert eff.truth.effect == 'dwell_time_stiction' and eff.truth.own_form
    assert eff.truth.effect_snr > 30.0 and eff.labels['magnitude'] == '>=30'
    assert set(eff.truth.library_params) == {'stiction_gain', 'stiction_tau'}
    assert eff.labels['motion'] in ('stick-slip', 'mixed', 'sliding')
    # measurement-only effect: the offset drift's rms (mean removed) over the noise
    spec = draw(40, family='torque_offset', duration=4.0)
    sc = generate(spec, cache_dir=tmp_path)
    t = spec.drive.record_start + sc.time
    p = spec.effect.params
    d = p['rate'] * t if spec.effect.form == 'linear' else p['D'] * (1 - np.exp(-t / p['tau']))
    expected = np.std(d) / spec.instrument.torque.noise
    assert sc.truth.effect_snr == pytest.approx(expected, rel=1e-9)


def test_the_generator_imports_nothing_from_the_tribo_packages():
    found = []
    for path in sorted(PKG.glob('*.py')):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            found += [(path.name, n) for n in names if n.split('.')[0].startswith('tribo')]
    assert found == [] and len(list(PKG.glob('*.py'))) >= 8


def test_command_writes_a_record_the_rig_csv_readers_take(tmp_path, capsys):
    assert main(['2', '--out', str(tmp_path / 'sc'), '--duration', '4']) == 0
    out = capsys.readouterr().out
    assert 'tribo discrepancy' in out
    lines = (tmp_path / 'sc' / 'record.csv').read_text().splitlines()
    assert lines[2] == 'time,torsion_moment,angular_acceleration,speed'
    assert all(x.startswith('#') for x in lines[:2])
    data = np.loadtxt(lines[3:], delimiter=',')
    assert data.shape == (int(4 * draw(2, duration=4.0).fs), 4)
    assert np.allclose(np.diff(data[:, 0]), 1 / draw(2).fs)
    rig = yaml.safe_load((tmp_path / 'sc' / 'rig.yaml').read_text())
    assert rig == pytest.approx(draw(2, duration=4.0).user_rig, rel=1e-12)
    assert (tmp_path / 'sc' / 'truth.json').is_file()
    # bad input: one line, exit code 2, nothing written
    assert main(['3', '--out', str(tmp_path / 'bad'), '--family', 'gremlins']) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and 'gremlins' in err[0]
    assert not (tmp_path / 'bad').exists()
    with pytest.raises(InvalidRequestError, match='seed'):
        draw(-1)
    with pytest.raises(InvalidRequestError, match='kind'):
        draw(1, kind='wobble')
