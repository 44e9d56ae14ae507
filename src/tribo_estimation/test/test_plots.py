"""Figures (paper Fig. 4-6 and the campaign view) from block tables."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tribo_estimation.plots import (
    CampaignRun,
    DetailTrace,
    _stick_spans,
    plot_blocks,
    plot_campaign,
    plot_detail,
    plot_mu_slip,
    stribeck,
)


def _table(n: int = 20, flagged: tuple[int, ...] = (0,)) -> dict[str, np.ndarray]:
    t = np.arange(n, dtype=float)
    q = np.array(['ok'] * n, dtype=object)
    for i in flagged:
        q[i] = 'startup'
    return {
        't_start': t,
        't_end': t + 1.0,
        'mu0': 0.13 - 0.001 * t,
        'mu_inf': np.full(n, 0.10),
        'mu0_se': np.full(n, 1e-4),
        'mu_inf_se': np.full(n, 1e-4),
        'moment_min': np.full(n, 40.0),
        'moment_max': np.full(n, 88.0),
        'moment_mean': np.full(n, 65.0),
        'motion': np.array(['stick-slip'] * n, dtype=object),
        'n_sticks': np.full(n, 60.0),
        'stick_fraction': np.full(n, 0.4),
        'rms_residual': np.full(n, 0.1),
        'quality': q,
    }


def _is_png(path: Path) -> bool:
    return path.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n' and path.stat().st_size > 5_000


def test_fig45_counts_flagged_blocks_apart(tmp_path: Path) -> None:
    good, bad = plot_blocks(_table(20, flagged=(0, 7)), tmp_path / 'b.png', 'run')
    assert (good, bad) == (18, 2)  # flagged blocks are drawn apart, never as estimates
    assert _is_png(tmp_path / 'b.png')


def test_long_runs_use_minutes_and_all_flagged_still_plots(tmp_path: Path) -> None:
    tab = _table(800, flagged=tuple(range(800)))
    assert plot_blocks(tab, tmp_path / 'b.png') == (0, 800)
    assert _is_png(tmp_path / 'b.png')


def test_stribeck_curve_is_equ8() -> None:
    v = np.array([0.0, 0.5, 10.0])
    mu = stribeck(v, 0.13, 0.10, 2.0)
    assert mu[0] == pytest.approx(0.13)  # mu(0) = mu0
    assert mu[1] == pytest.approx(0.03 * np.exp(-1.0) + 0.10)
    assert mu[2] == pytest.approx(0.10, abs=1e-9)  # mu -> mu_inf


def test_mu_slip_plot_with_and_without_points(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    v = rng.uniform(0.0, 5.0, 500)
    plot_mu_slip(_table(), tmp_path / 'm.png', 2.0, v, stribeck(v, 0.13, 0.10, 2.0))
    plot_mu_slip(_table(), tmp_path / 'm2.png', 2.0)
    assert _is_png(tmp_path / 'm.png') and _is_png(tmp_path / 'm2.png')


def test_stick_spans_cover_the_runs() -> None:
    t = np.arange(10) * 0.1
    stick = np.array([0, 1, 1, 0, 0, 1, 0, 0, 1, 1], dtype=bool)
    spans = _stick_spans(t, stick)
    np.testing.assert_allclose(np.array(spans), [[0.1, 0.3], [0.5, 0.6], [0.8, 1.0]])


def test_detail_plot(tmp_path: Path) -> None:
    t = np.arange(1000) * 1e-4
    m = 65 + 20 * np.sin(2 * np.pi * 60 * t)
    tr = DetailTrace('stick-slip', t, m, m, np.full_like(m, np.nan), m > 75)
    plot_detail([tr, tr], tmp_path / 'd.png')
    plot_detail([], tmp_path / 'e.png')
    assert _is_png(tmp_path / 'd.png') and _is_png(tmp_path / 'e.png')


def test_campaign_grid_two_oils_three_speeds(tmp_path: Path) -> None:
    runs = [
        CampaignRun(f'{rpm} rpm', oil, _table(10))
        for oil in ('oil A', 'oil B')
        for rpm in (10, 30, 60)
    ]
    assert plot_campaign(runs, tmp_path / 'c.png', 'A vs B') == (4, 3)
    assert _is_png(tmp_path / 'c.png')
    # uneven groups: the missing panel is left empty
    assert plot_campaign(runs[:4], tmp_path / 'c2.png') == (4, 3)
    with pytest.raises(ValueError, match='no runs'):
        plot_campaign([], tmp_path / 'c3.png')
