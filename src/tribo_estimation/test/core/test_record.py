"""core.record: the one record type (checks, findings, window, files)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from tribo_estimation.core.record import InputFindings, RigRecord
from tribo_estimation.errors import InvalidDataError


def _ramp(n: int = 200, fs: float = 1000.0, t0: float = 0.0) -> RigRecord:
    t = t0 + np.arange(n) / fs
    return RigRecord(t, 2.0 * t, np.zeros(n), np.full(n, 3.0))


def test_fs_from_time_and_given() -> None:
    r = _ramp(200, 1000.0, t0=1.5)
    assert r.fs == pytest.approx(1000.0, rel=1e-12) and r.dt == pytest.approx(1e-3, rel=1e-12)
    assert r.first_index == 1500 and len(r) == 200
    assert r.duration == pytest.approx(0.2, rel=1e-12)
    one = RigRecord(np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(1), fs=10.0)
    assert one.fs == 10.0  # a single sample needs its rate given
    with pytest.raises(InvalidDataError, match='no usable sample rate'):
        RigRecord(np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(1))


@pytest.mark.parametrize(
    ('change', 'message'),
    [
        (lambda t, x: (np.r_[t[:50], t[50:] + 0.5e-3], x), 'not uniformly sampled .* sample 50'),
        (lambda t, x: (np.r_[t[:10], t[9], t[11:]], x), 'not strictly increasing at sample 10'),
        (lambda t, x: (t, np.r_[x[:7], np.nan, x[8:]]), "'torsion_moment' has a non-finite .* 7"),
        (lambda t, x: (t, x[:-1]), "'torsion_moment' has shape"),
    ],
)
def test_bad_columns_named(
    change: Callable[..., tuple[np.ndarray, np.ndarray]], message: str
) -> None:
    t = np.arange(100) / 1000.0
    tt, x = change(t, np.ones(100))
    with pytest.raises(InvalidDataError, match=message):
        RigRecord(tt, x, np.zeros(tt.size), np.zeros(tt.size), source='r')


def test_findings_count_spikes_and_bursts() -> None:
    mask = np.zeros(50, dtype=bool)
    mask[[3, 10, 11]] = True  # a spike and a two-sample spike
    mask[20:25] = True  # a burst of 5
    f = InputFindings(mask)
    assert (f.spikes, f.bursts, f.quality) == (8, 1, 'spikes;bursts')
    assert f.summary() == {'spikes': 8, 'bursts': 1, 'quality': 'spikes;bursts'}
    assert InputFindings().summary() == {'spikes': 0, 'bursts': 0, 'quality': 'ok'}
    r = RigRecord(*(np.arange(50) / 100.0,) * 4, findings=f)
    assert np.array_equal(r.replaced, mask)
    with pytest.raises(InvalidDataError, match='findings mark 50 samples, the record has 10'):
        RigRecord(*(np.arange(10) / 100.0,) * 4, findings=f)


def test_window_keeps_rate_origin_and_findings() -> None:
    mask = np.zeros(200, dtype=bool)
    mask[120] = True
    r = RigRecord(
        *(np.arange(200) / 1000.0,) * 4, findings=InputFindings(mask), source='s', time_origin=5.0
    )
    w = r.window(0.1, 0.05)
    assert (w.first_index, len(w), w.source, w.time_origin) == (100, 50, 's', 5.0)
    assert np.array_equal(np.flatnonzero(w.replaced), [20])
    assert len(r.window(0.15)) == 50  # duration 0: to the end
    with pytest.raises(InvalidDataError, match='holds no sample'):
        r.window(1.0)


def test_discrepancy_and_monitor_records_are_this_type(
    sim_record: Callable[..., RigRecord],
) -> None:
    from tribo_estimation.core.discrepancy.fitting import Record
    from tribo_estimation.core.discrepancy.monitor import WindowData
    from tribo_estimation.core.simulate import SimResult

    assert Record is RigRecord and WindowData is RigRecord
    sim = sim_record(0.5, noise=False)
    assert isinstance(sim, SimResult) and isinstance(sim, RigRecord)
    assert sim.source == 'simulation' and sim.fs == 10_000.0


def test_write_and_frame_round_trip(sim_record: Callable[..., RigRecord], tmp_path: Path) -> None:
    from tribo_estimation.core.rigio import read_rig_csv

    sim = sim_record(0.3)
    back = read_rig_csv(sim.write(tmp_path / 'r.csv'))
    assert list(back.extra) == ['friction_moment', 'slip_speed', 'stick']  # the truth
    np.testing.assert_allclose(back.torsion_moment, sim.torsion_moment, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(back.time, sim.time, rtol=0, atol=1e-12)
    frame = sim.to_frame()
    assert list(frame.columns) == [
        'time', 'torsion_moment', 'angular_acceleration', 'speed', 'replaced',
    ]  # fmt: skip
    assert len(frame) == len(sim) == len(sim.rows())
    assert sim.rows()[7]['speed'] == sim.speed[7]
