"""core.inputs: the one input stage (CSV, bag or arrays -> checked events or a record)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

import tribo_estimation as te
from tribo_estimation.core import inputs
from tribo_estimation.core.align import AlignedChunk
from tribo_estimation.core.config import RigConfig
from tribo_estimation.core.record import RigRecord
from tribo_estimation.core.rigio import write_rig_csv
from tribo_estimation.errors import RecordBagError, TooShortError, UnitError

REPO = Path(__file__).resolve().parents[4]
RIG = REPO / 'config' / 'rig.yaml'


@pytest.fixture(scope='module')
def rig() -> RigConfig:
    return te.load_rig(RIG)


def _csv(path: Path, r: RigRecord, **change: np.ndarray) -> Path:
    cols = {n: r.channel(n) for n in ('time', 'torsion_moment', 'angular_acceleration', 'speed')}
    cols.update(change)
    write_rig_csv(path, *cols.values())
    return path


def test_csv_record_is_the_file_on_the_drive_time_base(
    sim_record: Callable[..., RigRecord], rig: object, tmp_path: Path
) -> None:
    sim = sim_record(2.0)
    rec = te.read_record(_csv(tmp_path / 'r.csv', sim), rig)
    assert (len(rec), rec.fs, rec.first_index) == (20_000, 10_000.0, 0)
    np.testing.assert_array_equal(rec.time, np.arange(20_000) / 1e4)
    # the CSV keeps 9 significant digits; a clean record is passed on unchanged
    np.testing.assert_allclose(rec.torsion_moment, sim.torsion_moment, rtol=1e-8, atol=1e-9)
    assert rec.findings.summary() == {'spikes': 0, 'bursts': 0, 'quality': 'ok'}
    assert rec.findings.stretches == 1 and rec.source == str(tmp_path / 'r.csv')


def test_window_and_too_short(
    sim_record: Callable[..., RigRecord], rig: object, tmp_path: Path
) -> None:
    p = _csv(tmp_path / 'r.csv', sim_record(2.0))
    w = te.read_record(p, rig, start=0.5, duration=0.25)
    assert (w.first_index, len(w)) == (5000, 2500)
    with pytest.raises(TooShortError, match=r'holds 50 samples \(need >= 100\)'):
        te.read_record(p, rig, start=1.0, duration=0.005)
    with pytest.raises(RecordBagError, match='no such file or bag'):
        te.read_record(tmp_path / 'missing.csv', rig)


def test_spikes_replaced_and_marked(
    sim_record: Callable[..., RigRecord], rig: object, tmp_path: Path
) -> None:
    sim = sim_record(2.0)
    tq = sim.torsion_moment.copy()
    tq[[4000, 12_345]] = [1e6, -1e6]  # far beyond any physical torque (N m)
    rec = te.read_record(_csv(tmp_path / 'r.csv', sim, torsion_moment=tq), rig)
    assert list(np.flatnonzero(rec.replaced)) == [4000, 12_345]
    # replaced by interpolation of the neighbours: within the noise (0.05 N m) x 10
    for i in (4000, 12_345):
        assert abs(rec.torsion_moment[i] - sim.torsion_moment[i]) < 0.5


def test_a_gap_gives_the_longest_stretch(
    sim_record: Callable[..., RigRecord], rig: object, tmp_path: Path
) -> None:
    sim = sim_record(2.0)
    keep = np.r_[0:6000, 6500:20_000]  # 500 samples missing after 0.6 s
    cols = [sim.channel(n)[keep] for n in ('time', 'torsion_moment', 'angular_acceleration',
                                           'speed')]  # fmt: skip
    write_rig_csv(tmp_path / 'g.csv', *cols)
    notes: list[str] = []
    rec = te.read_record(tmp_path / 'g.csv', rig, progress=notes.append)
    assert (rec.first_index, len(rec), rec.findings.stretches) == (6500, 13_500, 2)
    assert any('GapEvent' in n for n in notes) and any('longest' in n for n in notes)


def test_speed_at_rest_is_an_error_for_a_record(
    sim_record: Callable[..., RigRecord], rig: object, tmp_path: Path
) -> None:
    sim = sim_record(2.0)
    p = _csv(tmp_path / 'r.csv', sim, speed=sim.speed * 1e-3)
    with pytest.raises(UnitError, match='a free-decay record'):
        te.read_record(p, rig)
    # without a rig config only the time base and the spikes are checked
    assert len(te.read_record(p)) == 20_000


def test_stream_and_record_give_the_same_blocks(
    sim_record: Callable[..., RigRecord], rig: object, tmp_path: Path
) -> None:
    """fit_blocks on the file (streamed through CheckedInput) and on read_record's record
    (the same checks, collected) give identical blocks, spikes included."""
    sim = sim_record(3.0)
    tq = sim.torsion_moment.copy()
    tq[15_000] = 1e6
    p = _csv(tmp_path / 'r.csv', sim, torsion_moment=tq)
    streamed = te.fit_blocks(p, rig)
    recorded = te.fit_blocks(te.read_record(p, rig), rig)
    np.testing.assert_equal(streamed.rows(), recorded.rows())  # NaN equals NaN here
    assert [r['spikes'] for r in streamed.rows()] == [0, 1, 0]
    assert streamed.replaced == recorded.replaced == 1


def test_record_events_chunk_the_record(sim_record: Callable[..., RigRecord]) -> None:
    sim = sim_record(2.5)
    chunks = list(inputs.record_events(sim))
    assert [len(c) for c in chunks] == [10_000, 10_000, 5000]
    assert all(isinstance(c, AlignedChunk) and c.sample_rate == sim.fs for c in chunks)
    np.testing.assert_array_equal(np.concatenate([c.torsion for c in chunks]), sim.torsion_moment)
    assert chunks[1].first_index == 10_000 and chunks[1].t0 == pytest.approx(1.0, abs=1e-12)
