"""Down-sampling, stick flags and JSON of the live bridge core (no rclpy)."""

from __future__ import annotations

import json
import math
from types import SimpleNamespace

import numpy as np
import pytest

from tribo_bringup import bridge_core as bc
from tribo_bringup.errors import ConfigError

FS = 10_000.0


def feed(down: bc.Downsampler, data: np.ndarray, sizes: list[int], start: int = 0) -> list:
    out = []
    pos = start
    for n in sizes:
        out += down.push(
            pos, 1_000_000_000 + round(pos * 1e9 / FS), FS, data[pos - start : pos - start + n]
        )
        pos += n
    return out


def test_bins_independent_of_block_size() -> None:
    rng = np.random.default_rng(3)
    data = rng.normal(size=1000)
    a = feed(bc.Downsampler(200.0), data, [100] * 10)
    b = feed(bc.Downsampler(200.0), data, [37, 63, 1, 199, 300, 400])
    assert [p.index for p in a] == list(range(0, 1000, 50))
    assert a == b  # same bins, same floats: binning is on the absolute sample index
    for p in a:
        seg = data[p.index : p.index + 50]
        # exact: the same numpy reductions on the same slice
        assert p.mean == pytest.approx(seg.mean(), rel=1e-12, abs=1e-15)
        assert p.minimum == seg.min() and p.maximum == seg.max() and p.first == seg[0]
        assert p.stamp_ns == 1_000_000_000 + round(p.index * 1e5)


def test_slope_recovers_a_ramp() -> None:
    # torsion moment of a sticking chamber: C1*w*t; slope exact up to rounding
    t = np.arange(500) / FS
    data = 2338.6 * 3.0 * t + 5.0
    pts = feed(bc.Downsampler(200.0), data, [100] * 5)
    for p in pts:
        assert p.slope == pytest.approx(2338.6 * 3.0, rel=1e-9)


def test_gap_closes_open_bin_without_mixing() -> None:
    data = np.arange(400, dtype=float)
    down = bc.Downsampler(200.0)  # factor 50
    pts = down.push(0, 0, FS, data[:120])  # bins 0, 50 complete; 100..119 open
    assert [p.index for p in pts] == [0, 50]
    pts = down.push(300, 0, FS, data[300:400])  # gap: samples 120..299 lost
    assert pts[0].index == 100 and pts[0].n == 20 and pts[0].maximum == 119.0
    assert [p.index for p in pts[1:]] == [300, 350]
    assert all(p.n == 50 for p in pts[1:])


def test_unaligned_start_and_rate_change() -> None:
    down = bc.Downsampler(1000.0)
    pts = down.push(7, 0, FS, np.ones(18))  # factor 10: bins 7..9 (3 samples), 10..19; 20.. open
    assert [(p.index, p.n) for p in pts] == [(7, 3), (10, 10)]
    pts = down.push(25, 0, 1000.0, np.ones(5))  # new rate: open bin 20..24 flushed, factor 1
    assert [(p.index, p.n) for p in pts] == [(20, 5), (25, 1), (26, 1), (27, 1), (28, 1), (29, 1)]
    assert math.isnan(pts[-1].slope)


def test_bad_rates_are_rejected() -> None:
    with pytest.raises(ConfigError, match='rate'):
        bc.Downsampler(0.0)
    with pytest.raises(ConfigError, match='sample_rate'):
        bc.Downsampler(200.0).push(0, 0, float('nan'), [1.0])
    with pytest.raises(ConfigError, match='C1'):
        bc.StickDetector(C1=-1.0, tolerance=0.1)


def test_stick_detector_joins_streams() -> None:
    c1, w = 2338.6, 3.0
    t = np.arange(200) / FS
    torsion = np.concatenate([c1 * w * t[:100], np.full(100, c1 * w * t[99])])  # stick, then hold
    speed = np.full(200, w)
    tor_pts = feed(bc.Downsampler(200.0), torsion, [100, 100])
    spd_pts = feed(bc.Downsampler(200.0), speed, [100, 100])
    det = bc.StickDetector(C1=c1, tolerance=0.05)
    assert det.add_torsion(tor_pts) == []  # no speed yet: waits
    flags = det.add_speed(spd_pts)
    assert [f.index for f in flags] == [0, 50, 100, 150]
    assert [f.stick for f in flags] == [True, True, False, False]
    assert flags[0].w1 == pytest.approx(w, rel=1e-9)  # slope/C1 of an exact ramp
    msg = bc.stick_message(flags[2])
    assert msg['stick'] == 0 and msg['slip_speed'] == pytest.approx(w, abs=1e-9)


def test_record_message_bands_and_nan() -> None:
    stamp = SimpleNamespace(sec=12, nanosec=500_000_000)
    fields = {name: 0.0 for name in bc.WEAR_FIELDS}
    fields.update(
        t=600.0,
        wear_volume=2.0e-13,
        wear_volume_se=1.0e-14,
        wear_height=1.0e-7,
        wear_height_se=float('nan'),
        oil_mixed=True,
        quality='ok',
    )
    msg = SimpleNamespace(header=SimpleNamespace(stamp=stamp), **fields)
    out = bc.record_message(msg, bc.WEAR_FIELDS, bc.WEAR_BANDS)
    text = json.dumps(out, allow_nan=False)  # raises if a NaN slipped through
    back = json.loads(text)
    assert back['stamp'] == 12.5
    assert back['wear_volume_lo'] == pytest.approx(2.0e-13 - 2 * 1.0e-14, rel=1e-12)
    assert back['wear_volume_hi'] == pytest.approx(2.0e-13 + 2 * 1.0e-14, rel=1e-12)
    assert back['wear_height_se'] is None and back['wear_height_lo'] is None
    assert back['oil_mixed'] is True
    assert set(bc.WEAR_SCHEMA['properties']) == set(back)


def test_bin_message_modes() -> None:
    p = bc.BinPoint(
        index=50,
        stamp_ns=2_000_000_000,
        n=50,
        mean=1.5,
        minimum=1.0,
        maximum=2.0,
        first=1.25,
        slope=0.0,
    )
    assert bc.bin_message(p, 'N m', 'minmax')['value'] == 1.5
    m = bc.bin_message(p, 'N m', 'decimate')
    assert m['value'] == 1.25 and m['t'] == 2.0 and (m['min'], m['max']) == (1.0, 2.0)
    assert set(m) == set(bc.SAMPLES_SCHEMA['properties'])


def _layout_paths(node: object) -> list[str]:
    out: list[str] = []
    if isinstance(node, dict):
        for key, value in node.items():
            if key in ('value', 'topicPath') and isinstance(value, str):
                out.append(value)
            else:
                out += _layout_paths(value)
    elif isinstance(node, list):
        for item in node:
            out += _layout_paths(item)
    return out


def test_layout_uses_only_served_channels_and_fields() -> None:
    from pathlib import Path

    layout = json.loads(
        (Path(__file__).resolve().parents[3] / 'config' / 'foxglove_layout.json').read_text()
    )
    schemas = bc.channel_schemas()
    paths = _layout_paths(layout['configById'])
    assert len(paths) >= 15
    for path in paths:
        topic = next((t for t in schemas if path == t or path.startswith(t + '.')), None)
        assert topic is not None, f'{path}: no such bridge channel'
        field_name = path[len(topic) + 1 :]
        if field_name:
            assert field_name in schemas[topic]['properties'], f'{path}: field not in schema'
    # every panel of the layout tree is configured, every configured panel is placed
    placed: list[str] = []

    def walk(n: object) -> None:
        if isinstance(n, str):
            placed.append(n)
        elif isinstance(n, dict):
            walk(n['first'])
            walk(n['second'])

    walk(layout['layout'])
    assert sorted(placed) == sorted(layout['configById'])
