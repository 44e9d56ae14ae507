"""``tribo campaign``: spec, chunked sessions, store, a real local dask cluster, query, report.

Sessions are simulated 2 s bags written by ``tribo simulate --out`` (two oils with
mu0 = 0.13 and 0.14, two drive speeds); the reference numbers are those of the
single-session ``tribo friction`` command on the same bags.
"""

from __future__ import annotations

import csv
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from tribo_bringup import cli
from tribo_bringup.campaign.analyses import Task, n_chunks, run_task, session_duration
from tribo_bringup.campaign.query import query
from tribo_bringup.campaign.runner import RunSummary, analyse
from tribo_bringup.campaign.spec import CampaignSpec, Settings, load_spec
from tribo_bringup.campaign.store import Store
from tribo_bringup.errors import CampaignError, StoreBusyError
from tribo_estimation.core.blockfit import read_blocks_csv

REPO = Path(__file__).resolve().parents[3]
RIG_YAML = REPO / 'config' / 'rig.yaml'  # mu0 0.13, mu_inf 0.10, ramp 0.5 s
NVCT_YAML = REPO / 'config' / 'nvct.yaml'
#: Equal numbers: the campaign calls the same library functions on the same samples.
EXACT = 1e-12


def _simulate(rig: Path, out: Path, seconds: float, speed: float, seed: int) -> Path:
    args = ['simulate', '--rig', str(rig), '--duration', str(seconds), '--noise']
    args += ['--seed', str(seed), '--speed', str(speed), '--out', str(out)]
    assert cli.main(args) == 0
    return out


def _friction_cli(session: Path, rig: Path, out: Path) -> dict[str, np.ndarray]:
    assert cli.main([
        'friction', str(session), '--rig', str(rig), '--out', str(out), '--no-plots', '--quiet'
    ]) == 0  # fmt: skip
    return read_blocks_csv(out / 'blocks.csv')


@pytest.fixture(scope='module')
def campaign(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Spec dir: rig_A (mu0 0.13), rig_B (mu0 0.14), 2 s bags at 2 and 4 rad/s, spec.yaml."""
    d = tmp_path_factory.mktemp('campaign')
    text = RIG_YAML.read_text()
    (d / 'rig_A.yaml').write_text(text)
    (d / 'rig_B.yaml').write_text(text.replace('mu0: 0.13 ', 'mu0: 0.14 '))
    (d / 'runs').mkdir()
    for oil, seed in (('A', 1), ('B', 2)):
        for speed in (2.0, 4.0):
            name = f'{oil.lower()}{speed:.0f}'
            out = d / 'runs' / (f'{name}.mcap' if speed == 2.0 else name)  # file and folder
            _simulate(d / f'rig_{oil}.yaml', out, 2.0, speed, seed)
    (d / 'spec.yaml').write_text(
        'name: two oils\n'
        'analyses: [friction]\n'
        'groups:\n'
        '  - rig: rig_A.yaml\n'
        '    meta: {oil: A, date: 2026-03-01}\n'
        "    sessions: ['runs/a*']\n"
        '  - rig: rig_B.yaml\n'
        '    meta: {oil: B}\n'
        '    sessions:\n'
        '      - {path: runs/b2.mcap, meta: {speed_rpm: 19.1}}\n'
        '      - runs/b4\n'
    )
    return d


def _with_corrupt(campaign: Path, d: Path) -> Path:
    """Copy of the campaign with a cut MCAP (half its bytes) added to oil B and wear.

    The wear group is one simulated nVCT counts file (``tribo wear --simulate``).
    """
    shutil.copytree(campaign, d)
    data = (d / 'runs' / 'b2.mcap').read_bytes()
    (d / 'runs' / 'cut.mcap').write_bytes(data[: len(data) // 2])
    assert cli.main(['wear', '--simulate', str(d / 'runs' / 'counts.csv')]) == 0
    spec = (d / 'spec.yaml').read_text()
    spec = spec.replace('      - runs/b4\n', '      - runs/b4\n      - runs/cut.mcap\n')
    spec = spec.replace('analyses: [friction]', 'analyses: [friction, wear]')
    spec += f'  - nvct: {NVCT_YAML}\n    meta: {{oil: A}}\n    sessions: [runs/counts.csv]\n'
    (d / 'spec.yaml').write_text(spec)
    return d / 'spec.yaml'


@pytest.fixture(scope='module')
def analysed(campaign: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, int, str]:
    """The campaign with a corrupt bag, analysed by the CLI on 2 local workers.

    Returns (store, exit code, stderr's last line).
    """
    d = tmp_path_factory.mktemp('analysed')
    spec = _with_corrupt(campaign, d / 'c')
    store = d / 'store'
    proc = subprocess.run(
        [sys.executable, '-m', 'tribo_bringup.cli', 'campaign', 'analyse', str(spec),
         '--store', str(store), '--workers', '2'],
        capture_output=True, text=True, timeout=300, env=_env(),
    )  # fmt: skip
    return store, proc.returncode, proc.stderr.strip().splitlines()[-1]


def _env() -> dict[str, str]:
    paths = [str(REPO / 'src' / p) for p in ('tribo_bringup', 'tribo_common', 'tribo_estimation')]
    paths += [str(REPO / 'src' / 'tribo_nvct'), os.environ.get('PYTHONPATH', '')]
    return {**os.environ, 'PYTHONPATH': os.pathsep.join(paths)}


# --- spec ----------------------------------------------------------------------------


def test_spec_expands_globs_and_merges_metadata(campaign: Path) -> None:
    spec = load_spec(campaign / 'spec.yaml')
    ids = [s.session_id for s in spec.sessions]
    assert ids == ['runs/a2.mcap', 'runs/a4', 'runs/b2.mcap', 'runs/b4']
    a2, _, b2, _ = spec.sessions
    assert dict(a2.meta) == {'oil': 'A', 'date': '2026-03-01'}
    assert dict(b2.meta) == {'oil': 'B', 'speed_rpm': 19.1}
    assert a2.rig == campaign / 'rig_A.yaml' and a2.analyses == ('friction',)
    assert spec.settings == Settings()


@pytest.mark.parametrize(
    ('body', 'message'),
    [
        ('groups: [{rig: rig_A.yaml, sessions: [runs/zz*]}]', 'matches no file'),
        ('groups: [{rig: rig_A.yaml, sessions: [runs/a4], meta: {key: 1}}]', 'column of the store'),
        ('groups: [{sessions: [runs/a4]}]', 'needs a "rig" config'),
        ('groups: [{rig: rig_A.yaml, session: [runs/a4]}]', "did you mean 'sessions'"),
        ('analyses: [fricton]\ngroups: [{rig: rig_A.yaml, sessions: [runs/a4]}]', 'unknown'),
        ('settings: {chunk_s: 1.0}\ngroups: [{rig: rig_A.yaml, sessions: [runs/a4]}]', 'two'),
    ],
)
def test_bad_spec_is_one_line_exit_2(
    campaign: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], body: str, message: str
) -> None:
    spec = campaign / f'bad_{abs(hash(body))}.yaml'
    spec.write_text(body + '\n')
    with pytest.raises(CampaignError, match=message):
        load_spec(spec)
    rc = cli.main(['campaign', 'analyse', str(spec), '--store', str(tmp_path / 's')])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and message in err[0]
    assert not (tmp_path / 's').exists()  # nothing written for a bad spec


# --- chunks ----------------------------------------------------------------------------


def test_chunked_session_equals_the_single_session_command(tmp_path: Path) -> None:
    bag = _simulate(RIG_YAML, tmp_path / 'long', 5.0, 3.14159, 7)
    ref = _friction_cli(bag, RIG_YAML, tmp_path / 'ref')
    st = Settings(chunk_s=2.0)
    n = n_chunks(session_duration(bag, 'bag'), st)
    assert n == 3  # 5 s in 2 s chunks
    rows = []
    for c in range(n):
        res = run_task(Task('k', 'friction', c, n, str(bag), 'bag', str(RIG_YAML), '', st))
        assert res.error == ''
        rows += res.rows['blocks']
    assert [r['quality'] for r in rows] == list(ref['quality'])  # startup only in block 0
    for col in ('mu0', 'mu_inf', 'mu0_se', 'mu_inf_se', 'w0', 'n_sticks', 'rms_residual'):
        np.testing.assert_allclose([r[col] for r in rows], ref[col], rtol=EXACT, err_msg=col)


def test_discrepancy_task_equals_the_single_session_command(campaign: Path, tmp_path: Path) -> None:
    import json

    bag = campaign / 'runs' / 'a4'
    st = Settings(discrepancy_start_s=0.5, discrepancy_duration_s=1.0)
    res = run_task(Task('k', 'discrepancy', 0, 1, str(bag), 'bag', str(RIG_YAML), '', st))
    assert res.error == ''
    row = res.rows['discrepancy'][0]
    out = tmp_path / 'disc'
    args = ['discrepancy', str(bag), '--rig', str(RIG_YAML), '--out', str(out)]
    assert cli.main([*args, '--start', '0.5', '--duration', '1.0', '--no-plots']) == 0
    ref = json.loads((out / 'discrepancy.json').read_text())
    assert row['verdict'] == ref['verdict'] and row['finding'] == ref['finding']
    assert row['rms_baseline'] == pytest.approx(ref['baseline']['rms'], rel=EXACT)
    assert row['mu0'] == pytest.approx(ref['baseline']['params']['mu0'], rel=EXACT)
    assert row['window_s'] == pytest.approx(1.0, abs=2e-4)  # 10 kHz: one sample


# --- the analysed store ------------------------------------------------------------------


def test_corrupt_bag_fails_its_session_the_others_are_analysed(
    analysed: tuple[Path, int, str],
) -> None:
    store, rc, last = analysed
    assert rc == 2 and '1 of 6 sessions failed' in last and 'cut.mcap' in last
    _, rows = query(store, 'SELECT session_id, status, error FROM sessions ORDER BY 1')
    status = {r[0]: (r[1], r[2]) for r in rows}
    assert status['runs/cut.mcap'][0] == 'failed'
    assert 'truncated or corrupt' in str(status['runs/cut.mcap'][1])
    assert '\n' not in str(status['runs/cut.mcap'][1])
    assert all(v[0] == 'ok' for k, v in status.items() if k != 'runs/cut.mcap')
    _, n = query(store, "SELECT count(*) FROM blocks WHERE session_id = 'runs/cut.mcap'")
    assert n[0][0] == 0  # a failed session has no rows


def test_query_per_oil_mu0_equals_the_single_session_commands(
    analysed: tuple[Path, int, str], campaign: Path, tmp_path: Path
) -> None:
    store = analysed[0]
    expected: dict[str, list[float]] = {'A': [], 'B': []}
    for s in load_spec(campaign / 'spec.yaml').sessions:
        assert s.rig is not None
        tab = _friction_cli(s.path, s.rig, tmp_path / s.path.name)
        expected[str(s.meta['oil'])] += list(tab['mu0'][tab['quality'] == 'ok'])
    out = tmp_path / 'oil.csv'
    sql = (
        'SELECT oil, avg(mu0) AS mu0, count(*) AS n FROM blocks JOIN sessions USING (session_id) '
        "WHERE quality = 'ok' GROUP BY oil ORDER BY oil"
    )
    assert cli.main(['campaign', 'query', str(store), sql, '--csv', str(out)]) == 0
    with out.open() as fh:
        got = {r['oil']: (float(r['mu0']), int(r['n'])) for r in csv.DictReader(fh)}
    for oil, mu0 in expected.items():
        assert got[oil][1] == len(mu0)
        assert got[oil][0] == pytest.approx(float(np.mean(mu0)), rel=EXACT)
    assert got['A'][0] == pytest.approx(0.13, rel=0.01)  # and the truth, at the fit's accuracy
    assert got['B'][0] == pytest.approx(0.14, rel=0.01)


def test_wear_equals_the_single_session_command(
    analysed: tuple[Path, int, str], tmp_path: Path
) -> None:
    import json

    counts = analysed[0].parent / 'c' / 'runs' / 'counts.csv'
    out = tmp_path / 'wear'
    assert cli.main(['wear', str(counts), '--nvct', str(NVCT_YAML), '--out', str(out)]) == 0
    ref = json.loads((out / 'summary.json').read_text())
    cols, rows = query(analysed[0], "SELECT * FROM wear WHERE session_id = 'runs/counts.csv'")
    got = dict(zip(cols, rows[0], strict=True))
    for key in ('k_w_progressive', 'k_w_running_in', 'progressive_rate_um3_per_min', 'load_N'):
        assert got[key] == pytest.approx(ref[key], rel=EXACT), key


def test_rerun_analyses_nothing(analysed: tuple[Path, int, str], tmp_path: Path) -> None:
    store = analysed[0]
    spec = load_spec(store.parent / 'c' / 'spec.yaml')
    res = analyse(spec, store, workers=1, stream=None)
    assert (res.analysed, res.up_to_date, res.tasks, res.workers) == (0, 6, 0, 0)
    assert len(res.failures) == 1  # the cut bag stays failed: the same bytes fail the same way


def test_query_errors_are_one_line(
    analysed: tuple[Path, int, str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert cli.main(['campaign', 'query', str(analysed[0]), 'SELECT nope FROM blocks']) == 2
    assert cli.main(['campaign', 'query', str(tmp_path), 'SELECT 1']) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and 'nope' in err[0] and 'not a campaign store' in err[1]


def test_report_page_in_headless_chromium(analysed: tuple[Path, int, str], tmp_path: Path) -> None:
    browser = shutil.which('chromium') or shutil.which('chromium-browser')
    out = tmp_path / 'report'
    assert cli.main(['campaign', 'report', str(analysed[0]), '--out', str(out)]) == 0
    page = (out / 'index.html').read_text()
    for section in ('id="sessions"', 'id="fig45"', 'id="speed"', 'id="motion"'):
        assert section in page
    assert 'id="wear"' in page
    assert page.count('data:image/png;base64,') == 4 and 'http' not in page.split('<body>')[1]
    if browser is None:
        pytest.skip('no Chromium installed: page checked as text only')
    dom = subprocess.run(
        [browser, '--headless', '--no-sandbox', '--disable-gpu', '--dump-dom',
         (out / 'index.html').as_uri()],
        capture_output=True, text=True, timeout=120,
    ).stdout  # fmt: skip
    assert dom.count('<img') == 4 and 'runs/cut.mcap' in dom and 'failed' in dom


# --- a real cluster ------------------------------------------------------------------------


def test_killed_worker_task_runs_again_nothing_lost_nothing_twice(
    campaign: Path, tmp_path: Path
) -> None:
    import logging

    from dask.distributed import Client, LocalCluster

    spec = load_spec(campaign / 'spec.yaml')
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None,
                           silence_logs=logging.ERROR)  # fmt: skip
    client = Client(cluster)
    killed: list[int] = []
    try:
        pids = client.run(os.getpid)
        result: list[RunSummary] = []
        run = threading.Thread(
            target=lambda: result.append(
                analyse(spec, tmp_path / 'store', scheduler=cluster.scheduler_address, stream=None)
            )
        )
        run.start()
        deadline = time.monotonic() + 60
        while not killed and time.monotonic() < deadline:
            for worker, keys in client.processing().items():
                if keys and worker in pids:
                    os.kill(pids[worker], signal.SIGKILL)  # mid-task: first task imports ~1 s
                    killed.append(pids[worker])
                    break
            time.sleep(0.01)
        run.join(120)
    finally:
        client.close()
        cluster.close()
    assert killed and not run.is_alive()
    res = result[0]
    assert res.analysed == 4 and res.failures == ()
    _, prov = query(tmp_path / 'store', 'SELECT count(*), count(DISTINCT key) FROM provenance')
    assert prov[0] == (4, 4)  # each session committed once
    _, rows = query(tmp_path / 'store', 'SELECT session_id, index, mu0 FROM blocks ORDER BY 1, 2')
    assert [r[:2] for r in rows] == [(s, i) for s in sorted(_ids(spec)) for i in (0, 1)]
    ref = {s.session_id: _direct(s.path, s.rig) for s in spec.sessions}
    for sid, i, mu0 in rows:
        assert mu0 == pytest.approx(ref[str(sid)][int(i)], rel=EXACT)


def _ids(spec: CampaignSpec) -> list[str]:
    return [s.session_id for s in spec.sessions]


def _direct(path: Path, rig: Path | None) -> list[float]:
    res = run_task(Task('k', 'friction', 0, 1, str(path), 'bag', str(rig), '', Settings()))
    return [float(r['mu0']) for r in res.rows['blocks']]  # type: ignore[arg-type]


def test_second_run_is_refused_and_an_interrupted_run_resumes(
    campaign: Path, tmp_path: Path
) -> None:
    store = tmp_path / 'store'
    cmd = [sys.executable, '-m', 'tribo_bringup.cli', 'campaign', 'analyse',
           str(campaign / 'spec.yaml'), '--store', str(store), '--workers', '1']  # fmt: skip
    proc = subprocess.Popen(cmd, env=_env(), start_new_session=True, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)  # fmt: skip
    try:
        deadline = time.monotonic() + 60
        lock = store / '.lock'
        while time.monotonic() < deadline and not (lock.is_file() and lock.read_text().strip()):
            time.sleep(0.02)
        with pytest.raises(StoreBusyError, match=f'pid {proc.pid}'):
            analyse(load_spec(campaign / 'spec.yaml'), store, workers=1, stream=None)
        # interrupted while it holds the lock (its first session takes about a second,
        # the four a second or two: waiting for a committed result raced the run's end)
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 130, err
    results = store / 'results'
    done = _committed(results)
    assert len(done) < 4
    res = analyse(load_spec(campaign / 'spec.yaml'), store, workers=1, stream=None)
    assert (res.up_to_date, res.analysed, res.failures) == (len(done), 4 - len(done), ())
    assert not [p for p in results.iterdir() if p.name.startswith('.tmp-')]
    _, n = query(store, "SELECT count(*) FROM sessions WHERE status = 'ok'")
    assert n[0][0] == 4


def _committed(results: Path) -> list[Path]:
    if not results.is_dir():
        return []
    return [p for p in results.iterdir() if not p.name.startswith(('.', '_'))]


def test_store_refuses_a_second_lock_holder(tmp_path: Path) -> None:
    with (
        Store(tmp_path).lock(),
        pytest.raises(StoreBusyError, match='another campaign run'),
        Store(tmp_path).lock(),
    ):
        pass


def test_progress_bar_eta_and_status_lines(monkeypatch: pytest.MonkeyPatch) -> None:
    import io

    from tribo_bringup.campaign import progress as pg

    now = [100.0]
    monkeypatch.setattr(pg.time, 'monotonic', lambda: now[0])
    out = io.StringIO()
    bar = pg.Progress(tasks=4, sessions=2, stream=out)  # t0 = 100 s
    now[0] = 110.0
    bar.task_done()  # 1 of 4 tasks after 10 s: 30 s to go
    assert bar.eta() == pytest.approx(30.0, abs=1e-9)
    bar.session_done('runs/a: ok, 2 blocks', ok=True)
    now[0] = 115.0
    bar.task_done()  # 2 of 4 after 15 s: 15 s to go
    assert bar.eta() == pytest.approx(15.0, abs=1e-9)
    text = out.getvalue()
    assert '[1/2] runs/a: ok, 2 blocks\n' in text
    assert '1/4 tasks, 0/2 sessions, 10.0 s, ETA 30.0 s' in text
    assert '2/4 tasks' not in text  # into a pipe a bar line at most every 10 s
    bar.close()
    assert out.getvalue().endswith('2/4 tasks, 1/2 sessions, 15.0 s, ETA 15.0 s\n')
    assert pg.fmt_seconds(3725.0) == '1 h 02 min' and pg.fmt_seconds(185.0) == '3 min 05 s'
