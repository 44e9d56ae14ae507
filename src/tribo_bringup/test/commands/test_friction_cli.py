"""``tribo friction`` / ``tribo campaign``: CSV and bag input, outputs, bad input named."""

from __future__ import annotations

import csv
import math
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest

from tribo_bringup import cli
from tribo_estimation.core.blockfit import FILE_COLUMNS, read_blocks_csv
from tribo_estimation.core.model import DriveProfile, FrictionLaw, RigParams
from tribo_estimation.core.rigio import write_rig_csv
from tribo_estimation.core.simulate import NoiseSpec, SimResult, simulate

REPO = Path(__file__).resolve().parents[4]
RIG_YAML = REPO / 'config' / 'rig.yaml'  # mu0 0.13, mu_inf 0.10, 30 rpm, ramp 0.5 s
TRUTH = FrictionLaw(0.13, 0.10, 2.0)
W0 = 3.14159


@lru_cache(maxsize=1)
def _sim() -> SimResult:
    return simulate(
        RigParams.tab1(),
        TRUTH,
        DriveProfile(W0, 0.5),
        3.0,
        10_000.0,
        noise=NoiseSpec(0.05, 2.0, 0.005),
        seed=11,
    )


def _csv(path: Path, speed_factor: float = 1.0, drop: slice | None = None) -> Path:
    r = _sim()
    keep = np.ones(r.time.shape[0], bool)
    if drop is not None:
        keep[drop] = False
    write_rig_csv(
        path,
        r.time[keep],
        r.torsion_moment[keep],
        r.angular_acceleration[keep],
        r.speed[keep] * speed_factor,
    )
    return path


def _main(*argv: str) -> int:
    return cli.main(['friction', *argv, '--quiet'])


def test_csv_run_writes_blocks_and_figures(tmp_path: Path) -> None:
    out = tmp_path / 'out'
    assert _main(str(_csv(tmp_path / 'run.csv')), '--rig', str(RIG_YAML), '--out', str(out)) == 0
    with open(out / 'blocks.csv', newline='') as fh:
        header = next(csv.reader(fh))
    assert tuple(header) == FILE_COLUMNS
    tab = read_blocks_csv(out / 'blocks.csv')
    assert len(tab['t_start']) == 3
    assert tab['quality'][0].startswith('startup')
    for i in (1, 2):
        assert tab['quality'][i] == 'ok'
        assert tab['motion'][i] == 'stick-slip'
        # target tolerances: mu0 2 %, mu_inf 1 %
        assert abs(tab['mu0'][i] - TRUTH.mu0) < 0.02 * TRUTH.mu0
        assert abs(tab['mu_inf'][i] - TRUTH.mu_inf) < 0.01 * TRUTH.mu_inf
    for name in ('blocks.png', 'mu_slip.png', 'detail.png'):
        assert (out / name).stat().st_size > 10_000  # a real figure, not an empty file


def test_csv_time_gap_flags_the_block(tmp_path: Path) -> None:
    out = tmp_path / 'out'
    src = _csv(tmp_path / 'gap.csv', drop=slice(15_000, 15_500))  # 50 ms lost in block 1
    assert _main(str(src), '--rig', str(RIG_YAML), '--out', str(out), '--no-plots') == 0
    tab = read_blocks_csv(out / 'blocks.csv')
    assert 'gap' in tab['quality'][1]
    assert tab['quality'][2] == 'ok'


def test_bag_gives_the_same_blocks_as_csv(tmp_path: Path) -> None:
    from tribo_bringup import bagio

    r = _sim()
    store = bagio.typestore()
    SB = store.types['tribo_msgs/msg/SampleBlock']
    Header = store.types['std_msgs/msg/Header']
    Time = store.types['builtin_interfaces/msg/Time']
    bag = tmp_path / 'bag'
    n, step = r.time.shape[0], 250
    chans = {
        '/rig/torsion_moment': r.torsion_moment,
        '/rig/angular_acceleration': r.angular_acceleration,
        '/rig/speed': r.speed,
    }
    with bagio.BagWriter(bag) as w:
        for topic in chans:
            w.add_topic(topic, 'tribo_msgs/msg/SampleBlock')
        for i in range(0, n, step):
            ns = round(r.time[i] * 1e9)
            for topic, arr in chans.items():
                m = SB(
                    header=Header(
                        stamp=Time(sec=ns // 10**9, nanosec=ns % 10**9),
                        frame_id=topic.rsplit('/', 1)[1],
                    ),
                    sample_rate=10_000.0,
                    first_index=i,
                    unit='',
                    data=arr[i : i + step],
                )
                w.write_msg(topic, ns, m)
    out_bag, out_csv = tmp_path / 'ob', tmp_path / 'oc'
    assert _main(str(bag), '--rig', str(RIG_YAML), '--out', str(out_bag), '--no-plots') == 0
    assert (
        _main(
            str(_csv(tmp_path / 'r.csv')),
            '--rig',
            str(RIG_YAML),
            '--out',
            str(out_csv),
            '--no-plots',
        )
        == 0
    )
    a, b = read_blocks_csv(out_bag / 'blocks.csv'), read_blocks_csv(out_csv / 'blocks.csv')
    assert list(a['quality']) == list(b['quality'])
    # the CSV stores 9-10 significant digits: the estimates agree to that precision
    np.testing.assert_allclose(a['mu0'], b['mu0'], rtol=1e-6)
    np.testing.assert_allclose(a['mu_inf'], b['mu_inf'], rtol=1e-6)


def _err(capsys: pytest.CaptureFixture[str], *argv: str) -> str:
    assert _main(*argv) == 2  # bad input: one line, exit code 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    return err


def test_missing_column_is_named(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    src = tmp_path / 'bad.csv'
    src.write_text('time,torsion_moment,speed\n0,1,1\n0.0001,1,1\n')
    err = _err(capsys, str(src), '--rig', str(RIG_YAML), '--out', str(tmp_path / 'o'))
    assert 'angular_acceleration' in err


def test_speed_in_rpm_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # 30 rpm written as rpm: the rig CSV reader does not see an implausible value
    # (30 < 100 rad/s), the block check compares with the nominal speed
    src = _csv(tmp_path / 'rpm.csv', speed_factor=60.0 / (2.0 * math.pi))
    err = _err(capsys, str(src), '--rig', str(RIG_YAML), '--out', str(tmp_path / 'o'))
    assert 'rpm' in err


def test_missing_rig_key_is_named(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rig = tmp_path / 'rig.yaml'
    text = RIG_YAML.read_text().splitlines()
    rig.write_text('\n'.join(line for line in text if not line.startswith('C2:')) + '\n')
    err = _err(
        capsys, str(_csv(tmp_path / 'r.csv')), '--rig', str(rig), '--out', str(tmp_path / 'o')
    )
    assert "'C2'" in err


def test_missing_input_is_an_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    err = _err(
        capsys, str(tmp_path / 'nope.csv'), '--rig', str(RIG_YAML), '--out', str(tmp_path / 'o')
    )
    assert 'nope.csv' in err


def test_campaign_figure_from_dirs_and_yaml(tmp_path: Path) -> None:
    out = tmp_path / 'run'
    assert (
        _main(
            str(_csv(tmp_path / 'run.csv')), '--rig', str(RIG_YAML), '--out', str(out), '--no-plots'
        )
        == 0
    )
    fig = tmp_path / 'campaign.png'
    assert (
        cli.main(
            [
                'campaign',
                'plot',
                str(out),
                str(out),
                '--labels',
                '10 rpm',
                '30 rpm',
                '--out',
                str(fig),
            ]
        )
        == 0
    )
    assert fig.stat().st_size > 10_000
    spec = tmp_path / 'c.yaml'
    spec.write_text(
        f'title: two oils\nruns:\n'
        f'  - {{dir: {out}, label: 30 rpm, group: oil A}}\n'
        f'  - {{dir: {out}, label: 30 rpm, group: oil B}}\n'
    )
    fig2 = tmp_path / 'c2.png'
    assert cli.main(['campaign', 'plot', '--spec', str(spec), '--out', str(fig2)]) == 0
    assert fig2.stat().st_size > 10_000


def test_campaign_label_count_mismatch(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert (
        cli.main(
            [
                'campaign',
                'plot',
                str(tmp_path),
                '--labels',
                'a',
                'b',
                '--out',
                str(tmp_path / 'f.png'),
            ]
        )
        == 2
    )
    assert 'labels' in capsys.readouterr().err
