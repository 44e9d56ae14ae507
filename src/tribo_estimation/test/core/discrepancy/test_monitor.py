"""The live monitor's window schedule and its warm-up (records of config/rig.yaml)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from tribo_estimation.core.config import load_rig_config
from tribo_estimation.core.discrepancy.monitor import MonitorConfig, WindowMonitor, WindowResult
from tribo_estimation.core.simulate import SimResult

CFG = load_rig_config(Path(__file__).resolve().parents[5] / 'config' / 'rig.yaml')
FS = 10_000.0


def _monitor(window: float, hop: float) -> WindowMonitor:
    return WindowMonitor(
        CFG.rig, CFG.drive, k=CFG.friction.k, config=MonitorConfig(window=window, hop=hop)
    )


def test_a_window_is_due_every_hop_and_a_late_push_gives_only_the_newest() -> None:
    mon = _monitor(1.0, 0.5)
    t = np.arange(round(3.0 * FS)) / FS
    z = np.zeros_like(t)
    ends = []
    for a in range(0, t.size, 1000):  # 0.1 s chunks
        s = slice(a, a + 1000)
        ends += [float(w.time[-1]) for w in mon.add(t[s], z[s], z[s], z[s])]
    # the first window once 1 s is buffered, then one per hop (a window's last sample)
    np.testing.assert_allclose(ends, np.arange(1.0, 3.01, 0.5) - 1 / FS, atol=1e-9)
    late = _monitor(1.0, 0.5)
    (w,) = late.add(t, z, z, z)  # 3 s at once: five windows due, the newest only
    assert w.time[-1] == pytest.approx(t[-1]) and w.time.size == round(1.0 * FS)


def test_a_gap_starts_the_window_again() -> None:
    mon = _monitor(1.0, 0.5)
    t = np.arange(round(0.8 * FS)) / FS
    z = np.zeros_like(t)
    assert mon.add(t, z, z, z) == []
    # 0.8 s later the stream resumes 0.1 s after a gap: no window bridges it
    t2 = t[-1] + 0.1 + np.arange(round(0.8 * FS)) / FS
    assert mon.add(t2, z, z, z) == []
    (w,) = mon.add(t2[-1] + (1 + np.arange(round(0.3 * FS))) / FS, *[np.zeros(3000)] * 3)
    assert w.time[0] == pytest.approx(t2[0], abs=0.5 / FS)  # starts after the gap


def test_warm_up_leaves_the_monitor_as_it_was(
    sim_record: Callable[..., SimResult],
) -> None:
    rec = sim_record(2.0, FS, seed=3)
    cold, warm = _monitor(1.5, 0.5), _monitor(1.5, 0.5)
    took = warm.warm_up(CFG.friction)
    assert took > 0.0
    args = (rec.time, rec.torsion_moment, rec.angular_acceleration, rec.speed)
    (a,) = cold.add(*args)
    (b,) = warm.add(*args)
    ra, rb = cold.evaluate(a), warm.evaluate(b)
    # the warm-up's window is its own: the first real window is the same to the last bit
    # (fit, noise floor, null law and verdict)
    assert (ra.residual_rms, ra.mu0, ra.noise_floor) == (rb.residual_rms, rb.mu0, rb.noise_floor)
    assert ra.identifiable_reason == rb.identifiable_reason
    # nothing missing is a final verdict: no investigation asked for
    assert ra.verdict == 'nothing_missing' and ra.complete and 'incomplete' not in ra.quality


def _two_windows(
    sim_record: Callable[..., SimResult], mon: WindowMonitor | None = None
) -> tuple[WindowMonitor, WindowResult, WindowResult]:
    """Push a 2 s Tab. 1 record as 1.5 s, then 0.5 s: two windows of 1.5 s, hop 0.5 s."""
    rec = sim_record(2.0, FS, seed=3)
    mon = mon if mon is not None else _monitor(1.5, 0.5)
    chans = (rec.time, rec.torsion_moment, rec.angular_acceleration, rec.speed)
    n = round(1.5 * FS)
    (first,) = mon.push(*(c[:n] for c in chans))
    (second,) = mon.push(*(c[n:] for c in chans))
    return mon, first, second


def test_later_windows_pool_their_fresh_replicas_with_the_newest_earlier_ones(
    sim_record: Callable[..., SimResult],
) -> None:
    mon, first, second = _two_windows(sim_record)
    cfg = mon.config
    fresh = cfg.fresh_replicas
    for name, before in first.null[0].samples.items():
        after = second.null[0].samples[name]
        # the first window measured all its replicas; the second its own few, then the
        # newest of the first's
        assert len(before) == len(after) == cfg.replicas, name
        assert after[fresh:] == before[: cfg.replicas - fresh], name
        assert after[:fresh] != before[:fresh], name


def test_a_later_window_starts_its_baseline_fit_from_the_window_before(
    sim_record: Callable[..., SimResult], monkeypatch: pytest.MonkeyPatch
) -> None:
    # the windows overlap: the second window's baseline fit starts from the first's
    # values (find_missing_physics(previous=)), and both fit the same friction (Tab. 1
    # record: mu0 and mu_inf within 0.5 % of each other); a gap forgets it
    from tribo_estimation.core.discrepancy import monitor as mon_mod

    seen: list[tuple[dict[str, float], ...]] = []
    real = mon_mod.find_missing_physics

    def spy(*args: object, **kwargs: object) -> object:
        seen.append(tuple(kwargs.get('previous', ())))  # type: ignore[arg-type]
        return real(*args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(mon_mod, 'find_missing_physics', spy)
    mon, first, second = _two_windows(sim_record)
    assert seen[0] == ()
    assert seen[1] == (first.baseline,) and first.baseline['mu0'] > 0.0
    assert second.mu0 == pytest.approx(first.mu0, rel=5e-3)
    assert second.mu_inf == pytest.approx(first.mu_inf, rel=5e-3)
    mon.reset()
    _two_windows(sim_record, mon)
    assert seen[2] == ()
