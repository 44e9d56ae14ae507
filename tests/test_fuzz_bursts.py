"""Bursts (runs of 3-512 corrupted samples: a saturating channel, an ADC glitch) are
found, repaired, counted per block and left out of the fits.

Records come from the independent generator (core.reference_records: its own
equations of motion, not the fit's kernel), with the rig's noise. The property
test at the end (hypothesis; short profile in ``make test``, long in ``make fuzz``)
puts generated bursts into a record and runs ``tribo friction`` and ``tribo
discrepancy`` on it.
"""

from __future__ import annotations

import csv
import functools
import json
import math
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from support import ROOT
from test_fuzz_commands import LIMIT_S, check_failure, tribo, workdir

RIG = ROOT / 'config' / 'rig.yaml'
FS = 10_000.0


@functools.cache
def _config() -> Any:
    from tribo_estimation.core.config import load_rig_config

    return load_rig_config(RIG)


def _scales(rpm: float) -> Any:
    from tribo_estimation.core.plausibility import Scales
    from tribo_estimation.core.reference_records import rpm as rad_s

    cfg = _config()
    return Scales.of(cfg.rig, cfg.friction, rad_s(rpm))


@functools.cache
def _record(rpm: float, duration: float, fs: float = FS, seed: int = 4) -> tuple[np.ndarray, ...]:
    """A generated stick-slip record (start-up ramp 0.5 s) with the rig's noise."""
    from tribo_estimation.core.reference import SpeedProfile
    from tribo_estimation.core.reference_records import RecordSpec, make_record, rig_channels
    from tribo_estimation.core.reference_records import rpm as rad_s

    cfg = _config()
    tq, ac, sp = rig_channels(1.0)
    rec = make_record(
        RecordSpec(
            cfg.rig,
            cfg.friction,
            SpeedProfile.startup(rad_s(rpm), 0.5),
            torsion=tq,
            accel=ac,
            speed=sp,
            duration=duration,
            fs=fs,
            seed=seed,
        )
    )
    return rec.time, rec.torsion_moment, rec.angular_acceleration, rec.speed


# ----------------------------------------------------------------------------- detector
@pytest.mark.parametrize('rpm', [10.0, 25.0, 60.0])
def test_genuine_stick_slip_has_no_bursts(rpm: float) -> None:
    from tribo_estimation.core.plausibility import despike_chunk, find_bursts

    _, tq, ac, sp = _record(rpm, 2.0)
    sc = _scales(rpm)
    for x, s in ((tq, sc.torque), (ac, sc.accel), (sp, sc.speed)):
        assert not find_bursts(x, s).any()
    *_, mask = despike_chunk(tq, ac, sp, sc)
    assert int(mask.sum()) == 0  # nothing replaced at all


@pytest.mark.parametrize('length', [3, 10, 60])
@pytest.mark.parametrize('factor', [10.0, 100.0, 999.0])
@pytest.mark.parametrize('channel', [1, 2, 3])
def test_burst_found_exactly(length: int, factor: float, channel: int) -> None:
    from tribo_estimation.core.plausibility import despike_chunk

    cols = [np.array(c) for c in _record(30.0, 1.0)]
    sc = _scales(30.0)
    scale = (sc.torque, sc.accel, sc.speed)[channel - 1]
    i = 4321
    cols[channel][i : i + length] = -factor * scale  # a level far off the signal
    cols[channel][i + 1 : i + length : 3] *= 0.7  # not flat: an ADC glitch
    t, a, v, mask = despike_chunk(cols[1], cols[2], cols[3], sc)
    assert list(np.flatnonzero(mask)) == list(range(i, i + length))
    clean = _record(30.0, 1.0)[channel]
    fixed = (t, a, v)[channel - 1]
    # repaired by interpolation: within the signal's own range near the burst
    near = clean[i - 100 : i + length + 100]
    assert np.all(fixed[i : i + length] >= near.min() - 1e-9)
    assert np.all(fixed[i : i + length] <= near.max() + 1e-9)


def test_bursts_at_the_ends_and_a_lasting_step() -> None:
    from tribo_estimation.core.plausibility import find_bursts

    _, tq, _, _ = _record(30.0, 1.0)
    s = float(_scales(30.0).torque)
    x = tq.copy()
    x[:7] = 50 * s  # the record starts inside a burst
    x[-12:] = -50 * s  # and ends in one
    assert list(np.flatnonzero(find_bursts(x, s))) == [*range(7), *range(x.size - 12, x.size)]
    y = tq.copy()
    y[5000:] += 10 * s  # a lasting offset step is no burst
    assert not find_bursts(y, s).any()
    z = tq.copy()
    z[3000:3513] = 20 * s  # 513 samples: longer than BURST_MAX, left to the block checks
    assert not find_bursts(z, s).any()


@pytest.mark.parametrize(('fs', 'duration'), [(2000.0, 3.0), (1000.0, 5.0)])
def test_free_decay_far_above_its_median_has_no_bursts(fs: float, duration: float) -> None:
    """Without a rig config the scales are the record's medians (tribo decay): a long
    free decay starts 100x above them; its steps must not be taken for bursts, while
    a burst 10x above the start amplitude still is."""
    from tribo_estimation.core.config import load_rig_config
    from tribo_estimation.core.model import DriveProfile, FrictionLaw, RigParams
    from tribo_estimation.core.plausibility import Scales, despike_chunk
    from tribo_estimation.core.simulate import free_decay_state, simulate

    cfg = load_rig_config(ROOT / 'config' / 'rig_decay_example.yaml')
    rig = RigParams(**{**cfg.rig.__dict__, 'F_N': 0.0})
    r = simulate(rig, FrictionLaw(0.0, 0.0), DriveProfile(0.0), duration, fs,
                 initial=free_decay_state(0.01), noise=cfg.noise,
                 seed=np.random.default_rng(2))  # fmt: skip
    tq, ac, sp = r.torsion_moment, r.angular_acceleration, r.speed
    sc = Scales.from_data(tq, ac, sp)
    assert np.max(np.abs(tq)) > 20 * sc.torque  # the decay spans far more than its median
    t, a, _, _ = despike_chunk(tq, ac, sp, sc)
    np.testing.assert_array_equal(t, tq)  # nothing replaced in torsion and acceleration
    np.testing.assert_array_equal(a, ac)
    bad = tq.copy()
    i = tq.size // 2
    bad[i : i + 20] = 10 * np.max(np.abs(tq))
    t, *_ = despike_chunk(bad, ac, sp, Scales.from_data(bad, ac, sp))
    assert np.max(np.abs(t[i : i + 20])) <= np.max(np.abs(tq[i - 50 : i + 70]))


def test_steps_within_the_noise_are_no_bursts() -> None:
    from tribo_estimation.core.plausibility import find_bursts

    x = np.random.default_rng(5).normal(0.0, 1.0, 137)  # steps above 3 scales, in the noise
    assert not find_bursts(x, 0.1).any()
    x[60:70] += 100.0  # 100 noise levels: a burst
    assert list(np.flatnonzero(find_bursts(x, 0.1))) == list(range(60, 70))


def test_burst_across_chunk_edges_same_as_whole() -> None:
    from tribo_estimation.core.align import AlignedChunk
    from tribo_estimation.core.plausibility import SpikeLog, checked_chunks, despike_chunk

    t, tq, ac, sp = (np.array(c) for c in _record(30.0, 1.0))
    sc = _scales(30.0)
    s = float(sc.torque)
    for i, n in ((1990, 40), (5003, 3), (7000, 64)):  # straddling the 37-sample chunk edges
        tq[i : i + n] = 30 * s
    whole = despike_chunk(tq, ac, sp, sc)
    events = [
        AlignedChunk(k, float(t[k]), FS, tq[k : k + 37], ac[k : k + 37], sp[k : k + 37])
        for k in range(0, t.size, 37)
    ]
    log = SpikeLog()
    out = list(checked_chunks(events, sc, 'r', log, [], check_samples=500))
    got = np.concatenate([e.torsion for e in out if isinstance(e, AlignedChunk)])
    np.testing.assert_allclose(got, whole[0], rtol=1e-14, atol=0)  # interpolation rounding
    np.testing.assert_array_equal(log.mask(0, t.size), whole[3])
    assert log.total == 40 + 3 + 64


# ----------------------------------------------------------------------------- blocks
def _blocks(out: Path) -> list[dict[str, str]]:
    with (out / 'blocks.csv').open() as fh:
        return list(csv.DictReader(fh))


@functools.cache
def _friction_rows(name: str, channel: int, start: int, length: int, level: float) -> tuple:
    from tribo_estimation.core.rigio import write_rig_csv

    cols = [np.array(c) for c in _record(30.0, 3.2, 2000.0, 5)]
    if length:
        cols[channel][start : start + length] = level
    with workdir() as d:
        write_rig_csv(d / 'r.csv', *cols)
        r = tribo('friction', str(d / 'r.csv'), '--rig', str(RIG), '--out', str(d / 'o'),
                  '--no-plots', '--quiet')  # fmt: skip
        assert r.rc == 0, r.stderr
        return tuple(tuple(sorted(row.items())) for row in _blocks(d / 'o'))


@pytest.mark.parametrize('channel', [1, 2])
@pytest.mark.parametrize('length', [3, 10, 60])
@pytest.mark.parametrize('factor', [10.0, 100.0, 999.0])
def test_a_burst_changes_only_its_own_block(channel: int, length: int, factor: float) -> None:
    sc = _scales(30.0)
    scale = float((sc.torque, sc.accel)[channel - 1])
    clean = [dict(r) for r in _friction_rows('clean', 1, 0, 0, 0.0)]
    start = int(2.37 * 2000)  # in block 2
    burst = [dict(r) for r in _friction_rows('b', channel, start, length, factor * scale)]
    assert [r['bursts'] for r in burst] == ['0', '0', '1', '0']
    assert [r['spikes'] for r in burst] == ['0', '0', str(length), '0']
    assert burst[2]['quality'] == 'bursts' and clean[2]['quality'] == 'ok'
    for i in (0, 1, 3):  # neighbours untouched (bit-identical)
        assert burst[i] == clean[i]
    # its own block: mu0 within 1e-3 (relative) of the clean fit, as is mu_inf
    for key in ('mu0', 'mu_inf'):
        assert abs(float(burst[2][key]) / float(clean[2][key]) - 1.0) < 1e-3


def test_a_block_mostly_burst_is_not_fitted() -> None:
    from tribo_estimation.core.blockfit import BlockConfig, PendingBlock, evaluate_block

    cfg = _config()
    t, tq, ac, sp = _record(30.0, 2.0)
    n = 10_000
    rep = np.zeros(n, dtype=bool)
    for k in range(0, n, 200):  # 64 of every 200 samples replaced: 32 %
        rep[k : k + 64] = True
    blk = PendingBlock(1, n, float(t[n]), FS, tq[n:], ac[n:], sp[n:], np.ones(n, bool),
                       repaired=rep)  # fmt: skip
    det = evaluate_block(cfg.rig, cfg.friction, BlockConfig(nominal_speed=math.pi), blk)
    res = det.result
    assert set(res.quality) == {'bursts', 'repaired'} and not res.ok
    assert math.isnan(res.mu0) and math.isnan(res.mu_inf)
    assert (res.spikes, res.bursts) == (64 * 50, 50)


# ----------------------------------------------------------------------------- property
burst_op = st.tuples(
    st.sampled_from([1, 2]),  # torsion_moment, angular_acceleration
    st.floats(0.2, 0.75),  # where [fraction of the record]
    st.integers(3, 64),  # length [samples]
    st.sampled_from([-999.0, -100.0, -10.0, 10.0, 100.0, 999.0]),  # level [physical scales]
)


@settings(max_examples=max(1, settings.default.max_examples // 4))
@given(bursts=st.lists(burst_op, min_size=1, max_size=3))
def test_commands_on_records_with_bursts(bursts: list[tuple[int, float, int, float]]) -> None:
    """Friction and discrepancy on a record with generated bursts: exit 0 within the
    time limit, every burst counted, the blocks without a burst as on the clean
    record, the discrepancy fit as fast as on a clean record (well inside LIMIT_S)."""
    from tribo_estimation.core.rigio import write_rig_csv

    cols = [np.array(c) for c in _record(30.0, 3.2, 2000.0, 5)]
    sc = _scales(30.0)
    n = cols[0].size
    hit: set[int] = set()
    for ch, where, length, factor in bursts:
        i = int(where * n)
        cols[ch][i : i + length] = factor * float((sc.torque, sc.accel)[ch - 1])
        hit.update(range(i // 2000, (i + length - 1) // 2000 + 1))
    clean = [dict(r) for r in _friction_rows('clean', 1, 0, 0, 0.0)]
    with workdir() as d:
        write_rig_csv(d / 'r.csv', *cols)
        r = tribo('friction', str(d / 'r.csv'), '--rig', str(RIG), '--out', str(d / 'f'),
                  '--no-plots', '--quiet')  # fmt: skip
        assert r.rc == 0, r.stderr
        rows = _blocks(d / 'f')
        assert sum(int(row['bursts']) for row in rows) >= 1
        for b, row in enumerate(rows):
            if b not in hit:  # a block without a burst: as on the clean record (the
                # streaming observer carries a trace of a burst just before it: 1e-6)
                for key, val in row.items():
                    if key in ('mu0', 'mu_inf', 'mu0_se', 'mu_inf_se', 'rms_residual'):
                        a, c = float(val), float(clean[b][key])
                        assert math.isclose(a, c, rel_tol=1e-6) or (math.isnan(a) and math.isnan(c))
                    else:
                        assert val == clean[b][key], (key, row, clean[b])
            else:
                for key in ('mu0', 'mu_inf'):
                    mu = float(row[key])
                    assert math.isnan(mu) or 0.0 <= mu <= 2.0, row
        t0 = time.monotonic()
        r = tribo('discrepancy', str(d / 'r.csv'), '--rig', str(RIG), '--out', str(d / 'x'),
                  '--no-plots', '--candidates', 'torque_offset,viscous_friction',
                  '--max-effects', '1', '--start', '0.6', '--duration', '1.2')  # fmt: skip
        check_failure(r, 'discrepancy', d / 'x')
        assert r.rc == 0, r.stderr
        assert time.monotonic() - t0 < LIMIT_S
        # bursts wholly inside the window (0.6-1.8 s): counted in discrepancy.json
        inside = [
            (int(w * n), int(w * n) + m) for _, w, m, _ in bursts if 1200 < int(w * n) < 3600 - m
        ]
        rep = json.loads((d / 'x' / 'discrepancy.json').read_text())['input']
        assert rep['bursts'] >= (1 if inside else 0)
        assert rep['quality'] == ('ok' if rep['spikes'] == 0 else rep['quality'])
