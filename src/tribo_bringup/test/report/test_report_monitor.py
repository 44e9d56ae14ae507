"""The session report lists the live model monitor's windows (/model/discrepancy).

A bag with three ModelDiscrepancy windows (values written, so every number on the
page is known) comes back in the scan, the monitor section and results.json; a
bag without the topic has no monitor section.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from tribo_bringup import bagio
from tribo_bringup.report.page import Section
from tribo_bringup.report.scan import scan_bag
from tribo_bringup.report.sections import monitor_section

T0 = 1_700_000_000_000_000_000


def _write(path: Path, n: int, investigated: int | None = None) -> list[dict[str, object]]:
    store = bagio.typestore()
    MD = store.types['tribo_msgs/msg/ModelDiscrepancy']
    Header = store.types['std_msgs/msg/Header']
    Time = store.types['builtin_interfaces/msg/Time']
    written = []
    with bagio.BagWriter(path) as w:
        w.add_topic('/model/discrepancy', bagio.TOPIC_TYPES['/model/discrepancy'])
        order = list(range(n)) + ([investigated] if investigated is not None else [])
        for k, i in enumerate(order):
            inquiry = k >= n  # the investigation of window i, published after the windows
            stamp = T0 + (6 + 2 * i + (10 if inquiry else 0)) * 1_000_000_000
            # window 0: nothing missing; 1: viscous friction explains part; 2: it is named
            named = i > 0
            verdicts = (
                "nothing missing: the paper's model explains the record down to the noise",
                'not explained: {viscous_friction}',
                'found viscous_friction (viscous = 0.502 N m s/rad)',
            )
            vals = dict(
                t_start=2.0 * i,
                t_end=6.0 + 2.0 * i,
                n_samples=60_000,
                mu0=0.1286,
                mu_inf=0.1049,
                drive_speed=3.14159,
                residual_rms=0.31,
                residual_rms_accel=5.0,
                noise_floor=0.05,
                ratio=6.2,
                concentration='slip_end',
                concentration_share=0.62,
                candidate='viscous_friction' if named else '',
                param_names=['viscous'] if named else [],
                param_values=np.array([0.5 + 0.001 * i] if named else [], dtype=np.float64),
                param_units=['N m s/rad'] if named else [],
                candidate_rms=0.0534 if named else math.nan,
                identifiable=i == 2,
                identifiable_reason=verdicts[i % 3] + '; torque residual RMS 0.31 -> 0.31 N m',
                processing_time=0.8 + 0.1 * i,
                quality='investigation' if inquiry else ('partial' if i == 1 else 'ok'),
            )
            msg = MD(
                header=Header(stamp=Time(sec=stamp // 10**9, nanosec=stamp % 10**9), frame_id='m'),
                **vals,
            )
            w.write_msg('/model/discrepancy', stamp, msg)
            written.append(vals)
    return written


def test_monitor_windows_in_scan_section_and_results(tmp_path: Path) -> None:
    _write(tmp_path / 'bag', 3)
    scan = scan_bag(tmp_path / 'bag')
    assert len(scan.monitor) == 3
    assert scan.monitor[0]['candidate'] == '' and scan.monitor[0]['params'] == ''
    assert scan.monitor[2]['params'] == 'viscous = 0.502 N m s/rad'
    assert scan.monitor[0]['candidate_rms'] is None  # NaN -> null
    results: dict[str, object] = {}
    out = tmp_path / 'out'
    out.mkdir()
    sec = monitor_section(scan, results, out)
    assert isinstance(sec, Section) and sec.key == 'monitor'
    assert 'id="monitor-windows"' in sec.body and sec.body.count('<tr>') == 4  # header + 3
    assert '3 windows' in sec.body and 'Investigations (0)' in sec.body
    assert 'viscous = 0.501 N m s/rad' in sec.body and 'slip_end (0.62)' in sec.body
    assert 'not explained: {viscous_friction}' in sec.body  # the verdict column
    mon = results['monitor']
    assert isinstance(mon, dict)
    # per family the windows that name it and those where it explains only a part
    assert mon['windows'] == 3 and mon['investigations'] == 0
    assert mon['named'] == {'viscous_friction': 1}
    assert mon['partial'] == {'viscous_friction': 1}
    assert mon['processing_time_max_s'] == pytest.approx(1.0)
    assert mon['processing_time_median_s'] == pytest.approx(0.9)
    csv = (out / 'monitor_windows.csv').read_text().splitlines()
    assert len(csv) == 4 and csv[0].startswith('t_start,t_end,n_samples,')


def test_an_investigation_is_counted_apart_from_the_windows(tmp_path: Path) -> None:
    _write(tmp_path / 'bag', 2, investigated=2)  # windows 0, 1, then window 2's investigation
    scan = scan_bag(tmp_path / 'bag')
    results: dict[str, object] = {}
    sec = monitor_section(scan, results, tmp_path)
    assert sec is not None and sec.body.count('<tr>') == 4  # header + 2 windows + 1
    assert '2 windows' in sec.body and 'Investigations (1)' in sec.body
    mon = results['monitor']
    assert isinstance(mon, dict)
    assert mon['windows'] == 2 and mon['investigations'] == 1
    # the investigation's name counts; the window times are the windows' only (0.8, 0.9 s)
    assert mon['named'] == {'viscous_friction': 1} and mon['partial'] == {'viscous_friction': 1}
    assert mon['processing_time_max_s'] == pytest.approx(0.9)


def test_no_monitor_topic_no_section(tmp_path: Path) -> None:
    store = bagio.typestore()
    DC = store.types['tribo_msgs/msg/DetectorCounts']
    Header = store.types['std_msgs/msg/Header']
    Time = store.types['builtin_interfaces/msg/Time']
    with bagio.BagWriter(tmp_path / 'bag') as w:
        w.add_topic('/nvct/counts', bagio.TOPIC_TYPES['/nvct/counts'])
        msg = DC(
            header=Header(stamp=Time(sec=1, nanosec=0), frame_id='c'),
            seq=0,
            t_start=0.0,
            t_end=60.0,
            counts=10,
            live_time=59.0,
        )
        w.write_msg('/nvct/counts', T0, msg)
    scan = scan_bag(tmp_path / 'bag')
    results: dict[str, object] = {}
    assert monitor_section(scan, results, tmp_path) is None
    assert results['monitor'] is None
