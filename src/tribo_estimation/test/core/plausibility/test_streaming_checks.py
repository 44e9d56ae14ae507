"""The live pipeline runs the same input checks and spike repair as the offline path.

Records come from the independent reference generator (scipy DOP853), with spikes
on the torsion channel; the live path gets them as per-channel blocks of 500 samples
(``StreamingPipeline``), the offline path as aligner events through
``checked_chunks`` (what ``tribo friction`` does).
"""

from __future__ import annotations

import numpy as np
import pytest

from tribo_estimation.core.align import CHANNELS, ChannelAligner
from tribo_estimation.core.blockfit import BlockConfig, BlockEstimator, StreamingPipeline
from tribo_estimation.core.model import FrictionLaw, RigParams
from tribo_estimation.core.plausibility import Scales, SpikeLog, checked_chunks
from tribo_estimation.core.reference import SpeedProfile
from tribo_estimation.core.reference_records import (
    Channel,
    RecordSpec,
    RecordTruth,
    make_record,
    rig_channels,
    rpm,
)
from tribo_estimation.errors import UnitError

RIG = RigParams.tab1()
LAW = FrictionLaw(0.13, 0.10, 2.0)
W0 = rpm(30)
CFG = BlockConfig(block_length=1.0, nominal_speed=W0)
SCALES = Scales.of(RIG, LAW, W0)
CHUNK = 500


def _record(spikes: float) -> RecordTruth:
    tq, ac, sp = rig_channels(1.0)
    tq = Channel(noise=tq.noise, spike_rate=spikes, spike_amp=40.0)  # N m
    spec = RecordSpec(
        rig=RIG, friction=LAW, drive=SpeedProfile(((0.0, W0),)), torsion=tq, accel=ac,
        speed=sp, seed=11, duration=3.0, start_offset=1.0,
    )  # fmt: skip
    return make_record(spec)


def _channels(r: RecordTruth) -> dict[str, np.ndarray]:
    return dict(zip(CHANNELS, (r.torsion_moment, r.angular_acceleration, r.speed), strict=True))


def _live(r: RecordTruth, scales: Scales | None) -> list[object]:
    pipe = StreamingPipeline(RIG, LAW, CFG, scales)
    fs = 1.0 / float(r.time[1] - r.time[0])
    blocks = []
    data = _channels(r)
    for i in range(0, r.time.size, CHUNK):
        for name in CHANNELS:
            _, done, _ = pipe.push(name, i, fs, float(r.time[i]), data[name][i : i + CHUNK])
            blocks.extend(done)
    blocks.extend(pipe.flush())
    return [pipe.evaluate(b) for b in blocks]


def _offline(r: RecordTruth) -> list[object]:
    log = SpikeLog()
    est = BlockEstimator(RIG, LAW, CFG, repairs=log)
    al = ChannelAligner()
    fs = 1.0 / float(r.time[1] - r.time[0])
    data = _channels(r)
    events = []
    for i in range(0, r.time.size, CHUNK):
        for name in CHANNELS:
            events.extend(al.push(name, i, fs, float(r.time[i]), data[name][i : i + CHUNK]))
    events.extend(al.flush())
    out = []
    for ev in checked_chunks(events, SCALES, 'record', log, []):
        out.extend(d.result for d in est.feed(ev))
    out.extend(d.result for d in est.finish())
    return out


def test_live_blocks_equal_offline_blocks_with_spikes_repaired() -> None:
    r = _record(spikes=20.0)  # 20 spikes/s of 40 N m on a ~100 N m torsion channel
    live = _live(r, SCALES)
    off = _offline(r)
    assert len(live) == len(off) == 3
    for a, b in zip(live, off, strict=True):
        # same samples, same repairs: the same fit to rounding
        assert a.mu0 == pytest.approx(b.mu0, rel=1e-12)
        assert a.mu_inf == pytest.approx(b.mu_inf, rel=1e-12)
        assert a.spikes == b.spikes
    # the spikes were found and left out (about 20 per block)
    assert sum(a.spikes for a in live) >= 40
    # and the estimate after the start-up block is the truth within 1 % (mu0) / 0.5 % (mu_inf)
    for a in live[1:]:
        assert a.mu0 == pytest.approx(LAW.mu0, rel=0.01)
        assert a.mu_inf == pytest.approx(LAW.mu_inf, rel=0.005)


def test_live_pipeline_without_checks_sees_the_spikes() -> None:
    r = _record(spikes=20.0)
    assert sum(a.spikes for a in _live(r, None)) == 0


def test_live_pipeline_names_a_speed_channel_in_rpm() -> None:
    r = _record(spikes=0.0)
    r_rpm = r.speed * 30.0 / np.pi
    pipe = StreamingPipeline(RIG, LAW, CFG, SCALES)
    fs = 1.0 / float(r.time[1] - r.time[0])
    data = {**_channels(r), 'speed': r_rpm}
    with pytest.raises(UnitError, match='speed'):
        for i in range(0, r.time.size, CHUNK):
            for name in CHANNELS:
                pipe.push(name, i, fs, float(r.time[i]), data[name][i : i + CHUNK])
    # the error stays: every later block is refused with it, nothing is fitted
    with pytest.raises(UnitError):
        pipe.push('torsion_moment', r.time.size, fs, 0.0, np.zeros(CHUNK))


def test_release_completes_the_last_block_of_a_paused_stream() -> None:
    r = _record(spikes=0.0)
    pipe = StreamingPipeline(RIG, LAW, CFG, SCALES)
    fs = 1.0 / float(r.time[1] - r.time[0])
    data = _channels(r)
    blocks = []
    for i in range(0, r.time.size, CHUNK):
        for name in CHANNELS:
            blocks.extend(pipe.push(name, i, fs, float(r.time[i]), data[name][i : i + CHUNK])[1])
    # the spike repair holds the tail of the last chunk: the third block is not complete
    assert [b.index for b in blocks] == [0, 1] and pipe.holding
    # a node's timer releases only after an input pause (an hour here: not yet)
    assert pipe.release(idle=3600.0) == ([], [], []) and pipe.holding
    moments, more, _ = pipe.release()
    assert [b.index for b in more] == [2] and not pipe.holding
    # every input sample has its observer sample once released
    assert moments and moments[-1].first_index + moments[-1].moment.size == r.time.size
