"""Analysis commands on a bag whose recording was cut off: the good part is analysed
and written into OUT/partial/, then one error line names the file and the last good
message (exit 2)."""

from __future__ import annotations

import csv
import subprocess
from pathlib import Path

import pytest
from support import ROOT, make_rig_bag, tribo_cmd


@pytest.fixture(scope='module')
def cut_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 12 s rig bag (three 1 MiB MCAP chunks) cut at 75 % of its file, without
    metadata.yaml: a recording whose recorder died."""
    base = tmp_path_factory.mktemp('bags')
    full = base / 'full'
    make_rig_bag(full, 12.0)
    mcap = next(full.glob('*.mcap'))
    cut = base / 'cut'
    cut.mkdir()
    data = mcap.read_bytes()
    (cut / mcap.name).write_bytes(data[: int(len(data) * 0.75)])
    return cut


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(tribo_cmd(*args), capture_output=True, text=True, timeout=600)


def test_friction_writes_good_blocks_then_names_the_damage(cut_bag: Path, tmp_path: Path) -> None:
    out = tmp_path / 'f'
    r = _run(
        'friction',
        str(cut_bag),
        '--rig',
        str(ROOT / 'config' / 'rig.yaml'),
        '--out',
        str(out),
        '--no-plots',
        '--quiet',
    )
    assert r.returncode == 2, r.stderr
    last = r.stderr.strip().splitlines()[-1]
    assert str(cut_bag) in last and 'last good message #' in last, last
    assert not (out / 'blocks.csv').exists()  # nothing that looks like a whole result
    with (out / 'partial' / 'blocks.csv').open() as f:
        rows = list(csv.DictReader(f))
    # two complete chunks (about 8 s): at least 7 whole blocks are there and fitted
    assert len(rows) >= 7
    assert all(r['quality'] in ('ok', 'startup') for r in rows[:3]), rows[:3]


def test_discrepancy_window_before_the_damage_is_fine(cut_bag: Path, tmp_path: Path) -> None:
    out = tmp_path / 'd'
    r = _run(
        'discrepancy',
        str(cut_bag),
        '--rig',
        str(ROOT / 'config' / 'rig.yaml'),
        '--out',
        str(out),
        '--start',
        '0.5',
        '--duration',
        '1.5',
        '--no-plots',
    )
    # the window ends before the cut: reading stops there, nothing is damaged
    assert r.returncode == 0, r.stderr
    assert (out / 'discrepancy.json').is_file()
