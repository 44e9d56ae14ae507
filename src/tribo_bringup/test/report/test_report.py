"""Session report from a small synthetic bag: numbers on the page vs the CSV/JSON results.

The bag is written with bagio.BagWriter and rosbags messages (no ROS needed):
simulated stick-slip rig streams at 10 kHz (torsion moment, angular acceleration,
shaft speed; one speed block left out), one FrictionEstimate per block and
WearState messages with known values.
"""

from __future__ import annotations

import base64
import csv
import json
import os
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from tribo_bringup import bagio
from tribo_bringup.errors import BagError
from tribo_bringup.report import UM3, build_report, fmt

FS = 10_000.0
C1 = 2338.6
W = 3.0  # shaft speed [rad/s]
T0 = 1_700_000_000 * 1_000_000_000
UNITS = {
    '/rig/torsion_moment': 'N m',
    '/rig/angular_acceleration': 'rad/s^2',
    '/rig/speed': 'rad/s',
}


def _types() -> dict[str, Any]:
    return bagio.typestore().types


def _header(stamp_ns: int) -> Any:
    t = _types()
    sec, nsec = divmod(stamp_ns, 1_000_000_000)
    return t['std_msgs/msg/Header'](
        stamp=t['builtin_interfaces/msg/Time'](sec=sec, nanosec=nsec), frame_id=''
    )


#: Rig of the synthetic session (config/rig.yaml values, constant drive speed).
RIG = dict(
    I1=0.0109, K1=0.04034, C1=C1, I2=0.0315, K2=4.0, C2=5975.0, F_N=8000.0, R=0.08,
    mu0=0.13, mu_inf=0.10, k=2.0, nominal_speed=W,
)  # fmt: skip


def rig_signals(seconds: float) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Stick-slip rig streams from the simulator (Equ. 1-3, 8) with the rig's sensor
    noise (seed 3), and the simulator's true stick flags."""
    from tribo_estimation.core.config import rig_config_from_dict
    from tribo_estimation.core.simulate import NoiseSpec, simulate

    cfg = rig_config_from_dict(RIG)
    sim = simulate(
        cfg.rig, cfg.friction, cfg.drive, seconds, FS, noise=NoiseSpec(0.05, 2.0, 0.005), seed=3
    )
    signals = {
        '/rig/torsion_moment': sim.torsion_moment,
        '/rig/angular_acceleration': sim.angular_acceleration,
        '/rig/speed': sim.speed,
    }
    return signals, np.asarray(sim.stick, dtype=bool)


def write_bag(path: Path, *, seconds: float = 3.0, missing_block: int | None = None) -> dict:
    t = _types()
    n = int(seconds * FS)
    signals, stick = rig_signals(seconds)
    estimates = []
    wears = []
    with bagio.BagWriter(path) as w:
        for topic in (*UNITS, '/friction/estimate', '/nvct/wear'):
            w.add_topic(topic, bagio.TOPIC_TYPES[topic])
        for b, first in enumerate(range(0, n, 100)):
            stamp = T0 + round(first * 1e9 / FS)
            for topic, sig in signals.items():
                if b == missing_block and topic == '/rig/speed':
                    continue
                msg = t['tribo_msgs/msg/SampleBlock'](
                    header=_header(stamp),
                    sample_rate=FS,
                    first_index=first,
                    unit=UNITS[topic],
                    data=sig[first : first + 100].copy(),
                )
                w.write_msg(topic, stamp, msg)
            if first % int(FS) == 0 and first > 0:  # one estimate per second
                k = first // int(FS)
                est = dict(
                    t_start=k - 1.0,
                    t_end=float(k),
                    first_index=first - int(FS),
                    mu0=0.13 + 0.001 * k,
                    mu0_se=0.002,
                    mu_inf=0.10 - 0.0005 * k,
                    mu_inf_se=0.001,
                    k=2.0,
                    k_se=0.0,
                    moment_min=-1.0,
                    moment_max=float(k),
                    moment_mean=0.5,
                    motion='stick-slip' if k != 2 else 'slip-slip',
                    n_sticks=83,
                    stick_fraction=2 / 3,
                    rms_residual=0.05,
                    quality='ok',
                )
                estimates.append(est)
                w.write_msg(
                    '/friction/estimate',
                    stamp,
                    t['tribo_msgs/msg/FrictionEstimate'](header=_header(stamp), **est),
                )
                for j in range(3):
                    tt = (3 * (k - 1) + j + 1) * 3600.0
                    ws = dict(
                        t=tt,
                        tagged_volume=1e-14,
                        tagged_volume_se=1e-16,
                        wear_volume=(2.5e5 + 1000.0 * tt / 60.0) * UM3,
                        wear_volume_se=1e3 * UM3,
                        wear_height=1e-8 * tt / 3600.0,
                        wear_height_se=1e-10,
                        wear_rate=1000.0 / 60.0 * UM3,
                        wear_rate_se=1e-2 * UM3,
                        running_in_volume=2.5e5 * UM3,
                        running_in_volume_se=2e3 * UM3,
                        progressive_rate=1000.0 / 60.0 * UM3,
                        progressive_rate_se=0.5 * UM3,
                        oil_mixed=True,
                        quality='ok',
                    )
                    wears.append(ws)
                    w.write_msg(
                        '/nvct/wear',
                        stamp + j,
                        t['tribo_msgs/msg/WearState'](header=_header(stamp + j), **ws),
                    )
    return {'estimates': estimates, 'wear': wears, 'signals': signals, 'stick': stick}


class Tables(HTMLParser):
    """Collect cell texts of tables by id, and every src/href attribute."""

    def __init__(self) -> None:
        super().__init__()
        self.tables: dict[str, list[list[str]]] = {}
        self.refs: list[str] = []
        self.tags: set[str] = set()
        self._tid: str | None = None
        self._cell: list[str] | None = None

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        self.tags.add(tag)
        for k in ('src', 'href'):
            if a.get(k):
                self.refs.append(str(a[k]))
        if tag == 'table':
            self._tid = a.get('id') or ''
            self.tables.setdefault(self._tid, [])
        elif tag == 'tr' and self._tid is not None:
            self.tables[self._tid].append([])
        elif tag in ('td', 'th') and self._tid is not None:
            self._cell = []

    def handle_endtag(self, tag: str) -> None:
        if tag in ('td', 'th') and self._cell is not None and self._tid is not None:
            self.tables[self._tid][-1].append(''.join(self._cell).strip())
            self._cell = None
        elif tag == 'table':
            self._tid = None

    def handle_data(self, data: str) -> None:
        if self._cell is not None:
            self._cell.append(data)


@pytest.fixture(scope='module')
def report(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    base = tmp_path_factory.mktemp('report')
    truth = write_bag(base / 'bag', missing_block=5)
    rig = base / 'rig.yaml'
    rig.write_text(
        ''.join(f'{k}: {v}\n' for k, v in RIG.items())
        + 'effects: {stiction_gain: 0.02, stiction_tau: 0.05}\n'
    )
    nvct = Path(__file__).resolve().parents[4] / 'config' / 'nvct.yaml'
    bad_rig = base / 'bad_rig.yaml'  # the offline fit must fail on it, the report must not
    bad_rig.write_text('I1: 0.0109\n')
    res = build_report(
        base / 'bag',
        base / 'out',
        rig=rig,
        nvct=nvct,
        analyses=('friction',),
        analysis_rig=bad_rig,
        command=['tribo', 'report', 'bag', '--out', 'out'],
        progress=lambda s: None,
    )
    parser = Tables()
    parser.feed(res.html.read_text(encoding='utf-8'))
    return {'res': res, 'truth': truth, 'out': base / 'out', 'html': parser, 'rig': rig}


def test_friction_table_matches_csv_and_truth(report: dict[str, Any]) -> None:
    out, truth, page = report['out'], report['truth'], report['html']
    with (out / 'friction_blocks.csv').open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == len(truth['estimates']) == 2
    for row, est in zip(rows, truth['estimates'], strict=True):
        # the CSV keeps full precision (repr of the float read back from the bag)
        assert float(row['mu0']) == est['mu0'] and float(row['mu_inf']) == est['mu_inf']
        assert row['motion'] == est['motion']
    table = page.tables['friction-blocks'][1:]  # skip the header row
    for cells, row in zip(table, rows, strict=True):
        assert cells[1] == fmt(float(row['mu0'])) and cells[3] == fmt(float(row['mu_inf']))
        assert cells[5] == row['motion']
    results = json.loads((out / 'results.json').read_text())
    fr = results['friction']
    assert fr['mu0_max'] == max(e['mu0'] for e in truth['estimates'])
    assert fr['motion_types'] == {'slip-slip': 1, 'stick-slip': 1}
    kv = {r[0]: r[1] for r in page.tables['friction-summary']}
    assert kv['mu0_max'] == fmt(fr['mu0_max']) and kv['blocks_ok'] == '2'


NVCT = Path(__file__).resolve().parents[4] / 'config' / 'nvct.yaml'


def test_wear_summary_and_k_w(report: dict[str, Any]) -> None:
    out, truth, page = report['out'], report['truth'], report['html']
    results = json.loads((out / 'results.json').read_text())
    we = results['wear']
    last = truth['wear'][-1]
    assert we['wear_volume_m3'] == last['wear_volume']
    # Equ. 10, paper convention: k_w = rate / (L * stroke * f); exact arithmetic on the
    # inputs of config/nvct.yaml (load_N, stroke_m, frequency_hz)
    cfg = yaml.safe_load(NVCT.read_text())
    assert we['k_w_sliding_distance'] == 'paper'
    assert we['k_w_progressive_m3_per_N_m'] == pytest.approx(
        last['progressive_rate'] / (cfg['load_N'] * cfg['stroke_m'] * cfg['frequency_hz']),
        rel=1e-12,
    )
    kv = {r[0]: r[1] for r in page.tables['wear-summary']}
    assert kv['wear_volume_m3'] == fmt(we['wear_volume_m3'])
    assert kv['k_w_progressive_m3_per_N_m'] == fmt(we['k_w_progressive_m3_per_N_m'])
    with (out / 'wear_states.csv').open() as fh:
        rows = list(csv.DictReader(fh))
    assert [float(r['t']) for r in rows] == [w['t'] for w in truth['wear']]


def test_session_counts_the_missing_block(report: dict[str, Any]) -> None:
    out, page = report['out'], report['html']
    results = json.loads((out / 'results.json').read_text())
    speed = next(s for s in results['session']['streams'] if s['topic'] == '/rig/speed')
    assert speed['missing'] == 100 and speed['gaps'] == 1  # block 5 left out
    assert results['session']['missing_samples'] == 100
    kv = {r[0]: r[1] for r in page.tables['session-summary']}
    assert kv['missing samples (all streams)'] == '100'
    assert any('missing samples = 100' in line for line in report['res'].summary)
    assert len(report['res'].summary) == 5


def test_page_is_self_contained_with_provenance(report: dict[str, Any]) -> None:
    page, out = report['html'], report['out']
    assert 'script' not in page.tags and 'link' not in page.tags
    imgs = [r for r in page.refs if r.startswith('data:image/png;base64,')]
    assert len(imgs) >= 3  # mu per block, Fig. 6 detail, wear curve
    for ref in page.refs:
        assert ref.startswith(('data:image/png;base64,', '#')), ref
    png = base64.b64decode(imgs[0].split(',', 1)[1])
    assert png[:8] == b'\x89PNG\r\n\x1a\n'
    results = json.loads((out / 'results.json').read_text())
    prov = results['provenance']
    assert prov['command'] == 'tribo report bag --out out'
    for key in ('python', 'numpy', 'scipy', 'numba', 'rosbags', 'tribo_bringup'):
        assert prov['versions'][key]
    versions = {r[0]: r[1] for r in page.tables['versions'][1:]}
    assert versions['numpy'] == prov['versions']['numpy']


def test_failed_analysis_is_reported_not_raised(report: dict[str, Any]) -> None:
    results = json.loads((report['out'] / 'results.json').read_text())
    fr = results['analyses']['friction']
    assert fr['ok'] is False and 'bad_rig.yaml' in fr['reason']  # the bad input is named
    assert 'Unavailable' in report['res'].html.read_text()


def test_rig_table(report: dict[str, Any]) -> None:
    rows = {r[0]: r for r in report['html'].tables['rig-params'][1:]}
    assert rows['C1'][1] == fmt(2338.6, 6) and rows['C1'][2] == 'N m/rad'
    assert 'stiction_gain' in report['res'].html.read_text()


def test_empty_or_missing_bag_is_an_error(tmp_path: Path) -> None:
    with pytest.raises(BagError, match='no such bag'):
        build_report(tmp_path / 'nope', tmp_path / 'out', progress=lambda s: None)
    assert not (tmp_path / 'out').exists()  # nothing written for a bad input


def test_opens_in_headless_chromium(report: dict[str, Any], tmp_path: Path) -> None:
    browser = shutil.which('chromium') or (
        '/usr/bin/chromium' if os.path.exists('/usr/bin/chromium') else None
    )
    if browser is None:
        pytest.skip('headless Chromium not installed (/usr/bin/chromium): browser check skipped')
    shot = tmp_path / 'report.png'
    proc = subprocess.run(
        [
            browser,
            '--headless',
            '--no-sandbox',
            '--disable-gpu',
            '--enable-logging=stderr',
            '--v=0',
            f'--screenshot={shot}',
            '--window-size=1200,2400',
            report['res'].html.as_uri(),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert shot.is_file() and shot.stat().st_size > 10_000, proc.stderr[-2000:]
    console = [ln for ln in proc.stderr.splitlines() if 'CONSOLE' in ln or 'Uncaught' in ln]
    assert console == [], console


def test_block_results_become_estimates() -> None:
    from tribo_bringup import bridge_core as bc
    from tribo_bringup.report.analyses import block_estimate
    from tribo_estimation.core.blockfit import BlockResult

    common = dict(
        index=0, first_index=0, t_start=0.0, t_end=1.0, k=2.0, k_se=0.0, moment_min=-3.0,
        moment_max=40.0, moment_mean=18.0, rms_residual=0.05,
    )  # fmt: skip
    good = BlockResult(
        mu0=0.131, mu_inf=0.0987, mu0_se=0.002, mu_inf_se=0.001, motion='stick-slip',
        n_sticks=80, stick_fraction=0.61, **common,
    )  # fmt: skip
    bad = BlockResult(
        mu0=float('nan'), mu_inf=float('nan'), mu0_se=float('nan'), mu_inf_se=float('nan'),
        motion='steady', n_sticks=0, stick_fraction=0.0, quality=('no_sliding', 'short'),
        **common,
    )  # fmt: skip
    ests = [block_estimate(r, bc.FRICTION_FIELDS) for r in (good, bad)]
    assert [e['mu0'] for e in ests] == [0.131, None]  # nan -> None (never a number)
    assert ests[0]['n_sticks'] == 80 and ests[0]['quality'] == 'ok'
    assert ests[1]['quality'] == 'no_sliding;short'
    assert set(ests[0]) == set(bc.FRICTION_FIELDS)


def test_discrepancy_result_is_summarised_and_embedded() -> None:
    """A verdict that names nothing (a set the record cannot tell apart) reaches the page
    as that verdict, with the set and the experiment that would decide, not as 'no effect'."""
    from tribo_bringup.analyses.discrepancy import ANALYSIS
    from tribo_bringup.report import AnalysisOutcome, analysis_section
    from tribo_estimation.core.discrepancy.pipeline import Effect, MissingPhysics, Policy
    from tribo_estimation.core.discrepancy.pipeline.null import NullLaw
    from tribo_estimation.core.discrepancy.pipeline.result import RecordReport

    def effect(family: str, name: str, value: float, unit: str) -> Effect:
        return Effect(family, family, {name: value}, {name: 0.1 * value}, {name: unit},
                      (0.0531,), (1.04,), 0.97)  # fmt: skip

    lag = effect('frictional_lag', 'lag_tau', 0.00101, 's')
    shape = effect('stribeck_shape', 'stribeck_shape', -0.21, '-')
    law = NullLaw({'torsion_moment': (1.03, 1.05, 1.04), 'speed': (1.0, 1.02, 1.01)}, 0.01)
    rep = RecordReport(
        baseline={'mu0': 0.13, 'mu_inf': 0.1}, final={'mu0': 0.13, 'mu_inf': 0.1},
        rms_baseline=0.212, rms_final=0.212, noise_floor=0.05,
        statistics_baseline={'torsion_moment': 4.2}, statistics_final={'torsion_moment': 4.2},
        null=law, noise={}, instrument={}, drive={}, drift_outlier=False,
    )  # fmt: skip
    result = MissingPhysics(
        verdict='cannot_tell_apart',
        reason='frictional_lag, stribeck_shape each explain the mismatch down to the noise',
        experiment='a second drive speed or a speed step',
        named=(), alternatives=(lag, shape), partial=(lag, shape), records=(rep,),
        rounds=((lag, shape),), policy=Policy(), run_time=1.0, simulations=10,
    )  # fmt: skip
    finding = ANALYSIS.finding(result)
    assert finding.startswith('cannot tell apart: {frictional_lag, stribeck_shape}'), finding
    assert 'a second drive speed or a speed step would decide' in finding
    assert '0.212 -> 0.212 N m' in finding
    summary = ANALYSIS.summary(result)
    assert summary['verdict'] == 'cannot_tell_apart' and summary['added'] == []
    apart = summary['cannot_tell_apart']
    assert isinstance(apart, list)
    assert [e['family'] for e in apart] == ['frictional_lag', 'stribeck_shape']
    assert summary['experiment'] == 'a second drive speed or a speed step'
    res = AnalysisOutcome(
        'discrepancy', ok=True, directory='analyses/discrepancy', what='find_missing_physics(x)',
        seconds=1.0, note='analysed 5 s', summary=summary, finding=finding,
    )  # fmt: skip
    sec = analysis_section(res, 'Discrepancy')
    assert sec.available and 'id="discrepancy-finding"' in sec.body
    assert 'cannot tell apart' in sec.body and 'analysed 5 s' in sec.body
    assert 'stribeck_shape' in sec.body and 'a second drive speed or a speed step' in sec.body
    failed = analysis_section(AnalysisOutcome('wear', reason='no /nvct/counts'), 'Wear')
    assert not failed.available and 'no /nvct/counts' in failed.body


def test_git_provenance_or_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from tribo_bringup.report import git_state

    # git looks no further up than tmp_path (which may lie inside this repository)
    monkeypatch.setenv('GIT_CEILING_DIRECTORIES', str(tmp_path.parent))
    assert git_state(tmp_path) == (None, None)  # not a repository: nothing, no error
    if shutil.which('git') is None:
        pytest.skip('git not installed')
    env = {**os.environ, 'GIT_AUTHOR_NAME': 't', 'GIT_AUTHOR_EMAIL': 't@t',
           'GIT_COMMITTER_NAME': 't', 'GIT_COMMITTER_EMAIL': 't@t'}  # fmt: skip
    subprocess.run(['git', 'init', '-q', str(tmp_path)], check=True, env=env)
    (tmp_path / 'a.txt').write_text('1\n')
    subprocess.run(['git', '-C', str(tmp_path), 'add', 'a.txt'], check=True, env=env)
    subprocess.run(['git', '-C', str(tmp_path), 'commit', '-qm', 'x'], check=True, env=env)
    head = subprocess.run(
        ['git', '-C', str(tmp_path), 'rev-parse', 'HEAD'], capture_output=True, text=True
    ).stdout.strip()
    assert git_state(tmp_path) == (head, False)
    (tmp_path / 'a.txt').write_text('2\n')
    assert git_state(tmp_path) == (head, True)


def test_detail_uses_core_stick_detection(report: dict[str, Any]) -> None:
    from tribo_bringup.report import DETAIL_S, detail_trace
    from tribo_estimation.core.config import load_rig_config

    truth = report['truth']
    est = truth['estimates'][0]  # stick-slip block from sample 0; speed block 5 missing
    bag = report['out'].parent / 'bag'
    rig = load_rig_config(report['rig']).rig
    tr = detail_trace(bag, est, est['t_start'], rig, DETAIL_S)
    assert tr is not None
    n = round(DETAIL_S * FS)
    assert tr.time.size == n and tr.time[1] - tr.time[0] == pytest.approx(1.0 / FS, rel=1e-12)
    gap = np.zeros(n, dtype=bool)
    gap[500:600] = True  # the speed samples left out: no aligned samples there
    assert np.isnan(tr.torsion[gap]).all() and not tr.stick[gap].any()
    # the torsion trace is the recorded one, sample for sample
    np.testing.assert_array_equal(
        tr.torsion[~gap], truth['signals']['/rig/torsion_moment'][:n][~gap]
    )
    # against the simulator's truth: the core detection places both ends of each stick
    # within a few samples (about 30 ends in 0.25 s), so >= 97 % of samples agree; the
    # bridge's 1 ms-bin display detector found no stick at all on this record (54 %)
    stick = truth['stick'][:n]
    assert np.mean(tr.stick[~gap] == stick[~gap]) >= 0.97
    assert stick[~gap].any() and tr.stick.any()
    # without rig parameters no stick phases are drawn, the trace stays
    bare = detail_trace(bag, est, est['t_start'], None, DETAIL_S)
    assert bare is not None and not bare.stick.any()


def test_figures_written_and_block_table(report: dict[str, Any]) -> None:
    from tribo_bringup.report import block_table
    from tribo_estimation.core.blockfit import CSV_COLUMNS

    out, ests = report['out'], report['truth']['estimates']
    for name in ('friction_blocks.png', 'motion_detail.png', 'wear_states.png'):
        assert (out / name).read_bytes()[:8] == b'\x89PNG\r\n\x1a\n', name
    table = block_table([{**e, 'mu0': None} if i == 1 else e for i, e in enumerate(ests)])
    assert list(table) == list(CSV_COLUMNS)
    assert table['mu0'][0] == ests[0]['mu0'] and np.isnan(table['mu0'][1])  # None -> NaN
    assert list(table['motion']) == [e['motion'] for e in ests]


def test_offline_friction_fit_runs_through_the_library(
    report: dict[str, Any], tmp_path: Path
) -> None:
    """The offline block fit (the library call of ``tribo friction``) on the fixture bag:
    one row per 1 s block in analyses/friction/blocks.csv, mu_inf of the good blocks
    within 0.01 of the simulated 0.10, and its figure embedded."""
    bag = report['out'].parent / 'bag'
    res = build_report(
        bag, tmp_path / 'out', rig=report['rig'], analyses=('friction',), progress=lambda s: None
    )
    status = res.results['analyses']['friction']
    assert status['ok'] is True and status['call'].startswith('fit_blocks(')
    with (tmp_path / 'out' / 'analyses' / 'friction' / 'blocks.csv').open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 3  # 3 s of data, 1 s blocks
    good = [r for r in rows if r['quality'] == 'ok']
    assert good, rows
    for r in good:
        assert abs(float(r['mu_inf']) - RIG['mu_inf']) < 0.01, r
    page = res.html.read_text()
    assert 'analyses/friction/blocks.png' in page and 'id="friction-finding"' not in page


def test_report_blocks_equal_tribo_friction(report: dict[str, Any], tmp_path: Path) -> None:
    """The report's offline block fit and ``tribo friction`` read the bag through the one
    input stage and give the same blocks.csv, number for number (the fixture bag has a
    gap and a missing block, so gaps and checks are on the path)."""
    from tribo_bringup.cli import main

    bag = report['out'].parent / 'bag'
    build_report(
        bag, tmp_path / 'rep', rig=report['rig'], analyses=('friction',), progress=lambda s: None
    )
    assert main(['friction', str(bag), '--rig', str(report['rig']), '--out',
                 str(tmp_path / 'cli'), '--no-plots', '--quiet']) == 0  # fmt: skip
    rep = (tmp_path / 'rep' / 'analyses' / 'friction' / 'blocks.csv').read_text()
    cli = (tmp_path / 'cli' / 'blocks.csv').read_text()
    assert rep.count('\n') >= 4  # header + 3 blocks
    assert rep == cli


def test_bag_dwells_round_trip(tmp_path: Path) -> None:
    """/nvct/counts messages come back as the dwells written, in order."""
    from tribo_nvct.api import read_counts

    t = _types()
    written = [(60.0 * i, 60.0 * (i + 1), 1000 + 7 * i, 59.5) for i in range(4)]
    with bagio.BagWriter(tmp_path / 'bag') as w:
        w.add_topic('/nvct/counts', bagio.TOPIC_TYPES['/nvct/counts'])
        for i, (t0, t1, c, lt) in enumerate(written):
            stamp = T0 + i * 1_000_000_000
            msg = t['tribo_msgs/msg/DetectorCounts'](
                header=_header(stamp), seq=i, t_start=t0, t_end=t1, counts=c, live_time=lt
            )
            w.write_msg('/nvct/counts', stamp, msg)
    counts = read_counts(tmp_path / 'bag')
    assert counts.truncated == ''
    assert [(d.t_start, d.t_end, d.counts, d.live_time) for d in counts.dwells] == written


def test_report_imports_no_command_module() -> None:
    """The report and the analyses call library functions, never ``commands.*``."""
    import ast

    pkg = Path(__file__).resolve().parents[2] / 'tribo_bringup'
    files = [*sorted((pkg / 'report').glob('*.py')), *sorted((pkg / 'analyses').glob('*.py'))]
    assert len(files) >= 7
    for f in files:
        for node in ast.walk(ast.parse(f.read_text())):
            mods: list[str] = []
            if isinstance(node, ast.Import):
                mods = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                mods = [node.module]
            assert not any('commands' in m.split('.') for m in mods), f'{f.name}: {mods}'
