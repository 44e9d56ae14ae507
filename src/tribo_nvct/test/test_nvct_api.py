"""The Python API of tribo_nvct: cheap import, counts in, the files of tribo wear out."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

import tribo_nvct as tn
from tribo_nvct.core.simulate import ForwardSimulator, write_counts_csv

from .conftest import CONFIG_DIR


def test_import_is_cheap() -> None:
    code = (
        'import sys, tribo_nvct; '
        "print(sorted(m for m in ('numba', 'scipy', 'matplotlib', 'pandas') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == '[]'


@pytest.fixture(scope='module')
def counts_csv(tmp_path_factory: pytest.TempPathFactory, simulator: ForwardSimulator) -> Path:
    path = tmp_path_factory.mktemp('counts') / 'counts.csv'
    write_counts_csv(path, simulator.run(3), 'simulated test, seed 3')
    return path


def test_evaluate_wear_is_tribo_wear(
    counts_csv: Path, simulator: ForwardSimulator, tmp_path: Path
) -> None:
    """The result writes the bytes tribo wear writes, and its progressive rate meets the
    simulated truth within 3 combined standard errors."""
    from tribo_bringup.cli import main
    from tribo_nvct.results import UM3, WEAR_COLUMNS

    counts = tn.read_counts(counts_csv)
    wear = tn.evaluate_wear(counts, CONFIG_DIR / 'nvct.yaml')
    assert len(wear.points) == len(counts) == len(wear.rows()) > 100
    assert tuple(wear.to_frame().columns) == WEAR_COLUMNS
    files = wear.write(tmp_path / 'api') + wear.plot(tmp_path / 'api')
    assert [f.name for f in files] == ['wear.csv', 'summary.json', 'wear.png']
    nvct = str(CONFIG_DIR / 'nvct.yaml')
    assert main(['wear', str(counts_csv), '--nvct', nvct, '--out', str(tmp_path / 'cli')]) == 0
    for name in ('wear.csv', 'summary.json'):
        assert (tmp_path / 'api' / name).read_bytes() == (tmp_path / 'cli' / name).read_bytes()
    s = wear.summary()
    truth = simulator.paper_truth()['progressive_rate'] * 60.0 / UM3  # um^3/min
    rate = s['progressive_rate_um3_per_min']
    se = s['progressive_rate_combined_se_um3_per_min']
    assert isinstance(rate, float) and isinstance(se, float)
    assert abs(rate - truth) < 3.0 * se, (rate, truth, se)


def test_bad_counts_named(tmp_path: Path) -> None:
    from tribo_nvct.errors import CountsBagError, CountsFileError

    with pytest.raises(CountsBagError, match='no such file or bag'):
        tn.read_counts(tmp_path / 'missing.csv')
    bad = tmp_path / 'bad.csv'
    bad.write_text('t_start,t_end,counts,live_time\n0,60,abc,59\n')
    with pytest.raises(CountsFileError, match='line 2: bad or missing value'):
        tn.read_counts(bad)
    with pytest.raises(Exception, match="unknown sliding-distance convention 'x'"):
        tn.load_nvct(CONFIG_DIR / 'nvct.yaml', convention='x')
