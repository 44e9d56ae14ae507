"""The Python API: cheap to import, documented, typed results, the CLI's errors."""

from __future__ import annotations

import inspect
import json
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

import tribo_estimation as te
from tribo_estimation.core.record import RigRecord

REPO = Path(__file__).resolve().parents[3]
RIG = REPO / 'config' / 'rig.yaml'


def test_import_is_cheap() -> None:
    """``import tribo_estimation`` loads no numba, scipy, matplotlib or pandas (PEP 562)."""
    code = (
        'import sys, tribo_estimation as te; te.__all__; '
        "print(sorted(m for m in ('numba', 'scipy', 'matplotlib', 'pandas') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == '[]'


def test_every_public_name_is_documented() -> None:
    """Every exported function has a numpy docstring with Parameters and Returns (as
    python-control checks), and every exported name resolves."""
    for name in te.__all__:
        obj = getattr(te, name)
        doc = inspect.getdoc(obj) or ''
        assert doc.split('\n')[0].endswith('.'), name
        if inspect.isfunction(obj):
            assert 'Parameters\n----------' in doc and 'Returns\n-------' in doc, name
    with pytest.raises(AttributeError, match='no attribute'):
        te.no_such_name  # noqa: B018


def test_block_fit_result(sim_record: Callable[..., RigRecord], tmp_path: Path) -> None:
    from tribo_estimation.core.blockfit import FILE_COLUMNS, read_blocks_csv

    rig = te.load_rig(RIG)
    fit = te.fit_blocks(sim_record(3.0), rig)
    assert len(fit) == 3 and len(fit.ok) == 2  # the first block is the start-up ramp
    frame = fit.to_frame()
    assert tuple(frame.columns) == FILE_COLUMNS and len(frame) == 3
    s = fit.summary()
    # truth of config/rig.yaml: mu0 0.13, mu_inf 0.10 (noise 0.05 N m): within 0.002
    assert abs(s['mu0_mean'] - 0.13) < 0.002 and abs(s['mu_inf_mean'] - 0.10) < 0.002  # type: ignore[operator]
    files = fit.write(tmp_path) + fit.plot(tmp_path)
    assert [f.name for f in files] == ['blocks.csv', 'blocks.png', 'mu_slip.png', 'detail.png']
    table = read_blocks_csv(tmp_path / 'blocks.csv')
    np.testing.assert_array_equal(table['mu0'], frame['mu0'].to_numpy())
    assert not any('nominal_speed' in n for n in fit.notices())  # the drive runs at nominal


def test_decay_result(tmp_path: Path) -> None:
    from tribo_estimation.core.config import load_rig_config
    from tribo_estimation.core.simulate import simulate_free_decay

    cfg = load_rig_config(REPO / 'config' / 'rig_decay_example.yaml')
    sim = simulate_free_decay(cfg.rig, 0.01, 2.0, 10_000.0)
    fit = te.identify_decay(sim)
    for name, truth in (('I1', cfg.rig.I1), ('K1', cfg.rig.K1), ('C1', cfg.rig.C1)):
        assert abs(fit.summary()[name] - truth) < 0.01 * truth, name  # type: ignore[operator]
    assert [r['name'] for r in fit.rows()] == ['I1', 'K1', 'C1', 'f_n_hz', 'zeta']
    assert len(fit.to_frame()) == 5
    assert [p.name for p in fit.write(tmp_path) + fit.plot(tmp_path)] == ['decay.json', 'decay.png']
    data = json.loads((tmp_path / 'decay.json').read_text())
    assert data['units']['C1'] == 'N m/rad' and data['input'] == 'simulation'


def test_bad_input_raises_the_line_the_cli_prints(
    sim_record: Callable[..., RigRecord], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from tribo_bringup.cli import main
    from tribo_estimation.core.rigio import write_rig_csv
    from tribo_estimation.errors import UnitError

    sim = sim_record(2.0)
    p = tmp_path / 'rpm.csv'
    write_rig_csv(p, sim.time, sim.torsion_moment, sim.angular_acceleration, sim.speed * 9.5493)
    with pytest.raises(UnitError) as err:
        te.fit_blocks(p, RIG)
    assert main(['friction', str(p), '--rig', str(RIG), '--out', str(tmp_path / 'o')]) == 2
    assert capsys.readouterr().err.strip() == f'tribo friction: error: {err.value}'
    assert 'speed looks like rpm' in str(err.value)
