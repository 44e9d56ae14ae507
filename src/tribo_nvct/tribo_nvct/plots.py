"""Figures of the nVCT wear evaluation (paper 3.5, Fig. 10-12).

All functions draw with the non-interactive Agg backend into PNG files; they
serve ``tribo wear`` and the session report alike (the one place the wear
figures are drawn). Volumes are shown in um^3, test time in min; the inputs
are SI (m^3, s).

- :func:`plot_wear_run`: one evaluated test (per-dwell wear volume, the
  progressive line of the 120-180 min window, running-in volume, the
  exponential running-in model; Fig. 10/11);
- :func:`plot_wear_states`: the live wear monitor's states (Fig. 10/11 style);
- :func:`plot_campaign_kw`: wear coefficients of several runs against load,
  temperature, stroke and frequency (Fig. 12).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use('Agg')

import matplotlib.pyplot as plt
import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:
    from tribo_nvct.core.config import NvctConfig
    from tribo_nvct.core.evaluation import Evaluation
    from tribo_nvct.core.wear import WearPoint

#: m^3 per um^3 (display unit of wear volumes).
UM3 = 1e-18

FloatArray = npt.NDArray[np.float64]


def plot_wear_run(
    path: str | Path, pts: Sequence[WearPoint], ev: Evaluation, cfg: NvctConfig
) -> Path:
    """Fig. 10/11: wear volume over test time of one evaluated test.

    ``pts`` the per-dwell wear points (V_W [m^3] with standard errors), ``ev`` the
    evaluation (progressive rate [m^3/s], running-in volume [m^3], window [s],
    exponential model), ``cfg`` the run's configuration (label, load [N], contact
    area [m^2] for the mean-wear-height axis [nm]). Returns ``path``.
    """
    t = np.array([p.t_mid for p in pts], dtype=float) / 60.0
    v = np.array([p.volume for p in pts], dtype=float) / UM3
    se = np.array([p.volume_se for p in pts], dtype=float) / UM3
    ok = np.array([p.usable for p in pts], dtype=bool)
    fig, ax = plt.subplots(figsize=(8, 5))
    ax.errorbar(
        t[ok],
        v[ok],
        yerr=se[ok],
        fmt='.',
        ms=3,
        lw=0.5,
        color='C0',
        label='nVCT wear volume (per dwell)',
    )
    if np.any(~ok):
        ax.plot(t[~ok], v[~ok], 'x', ms=4, color='0.6', label='not mixed / beyond profile')
    t1, t2 = ev.window_s
    if math.isfinite(ev.progressive_rate):
        tt = np.array([0.0, t2])
        ax.plot(
            tt / 60.0,
            (ev.running_in_volume + ev.progressive_rate * tt) / UM3,
            '--',
            color='C3',
            label=f'progressive {ev.progressive_rate * 60 / UM3:.4g} um^3/min',
        )
        ax.axhline(
            ev.running_in_volume / UM3,
            color='C2',
            ls=':',
            label=f'running-in {ev.running_in_volume / UM3:.4g} um^3',
        )
        ax.axvspan(t1 / 60.0, t2 / 60.0, color='C3', alpha=0.07, label='regression window')
    if ev.exp_fit.ok:
        t_end = max(float(t.max()) if t.size else 0.0, t2 / 60.0)
        tt = np.linspace(0.0, t_end, 400) * 60.0
        ax.plot(
            tt / 60.0,
            ev.exp_fit.value(tt) / UM3,
            '-',
            color='k',
            lw=1,
            label=f'V_r(1-exp(-t/tau)) + w t, tau={ev.exp_fit.tau / 60:.3g} min',
        )
    ax.set_xlabel('test time [min]')
    ax.set_ylabel('wear volume [um^3]')
    ax.set_title(f'nVCT online wear ({cfg.label}, {cfg.load:g} N)')
    area = float(cfg.contact_area)

    def to_nm(x: npt.ArrayLike) -> FloatArray:
        return np.asarray(x, dtype=float) * (UM3 / area * 1e9)

    def to_um3(h: npt.ArrayLike) -> FloatArray:
        return np.asarray(h, dtype=float) * (1e-9 * area / UM3)

    sec = ax.secondary_yaxis('right', functions=(to_nm, to_um3))
    sec.set_ylabel('mean wear height [nm]')
    ax.legend(loc='lower right', fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return Path(path)


def plot_wear_states(
    path: str | Path,
    t: FloatArray,
    volume: FloatArray,
    volume_se: FloatArray,
    running_in_volume: float | None,
    progressive_rate: float | None,
    window_min: tuple[float, float],
) -> Path:
    """Fig. 10/11 style from the live wear monitor's states.

    ``t`` test time [s], ``volume`` wear volume V_W and ``volume_se`` its standard
    error [m^3] per state (NaN where unknown); ``running_in_volume`` [m^3] and
    ``progressive_rate`` [m^3/s] of the last state (None: no line drawn);
    ``window_min`` the progressive-rate window [min], shaded. Returns ``path``.
    """
    t_min = np.asarray(t, dtype=float) / 60.0
    v = np.asarray(volume, dtype=float) / UM3
    se = np.asarray(volume_se, dtype=float) / UM3
    fig, ax = plt.subplots(figsize=(9, 4.2))
    ax.fill_between(t_min, v - 2 * se, v + 2 * se, color='tab:brown', alpha=0.25, label='+-2 SE')
    ax.plot(t_min, v, '.', ms=3, color='tab:brown', label='wear volume V_W')
    if progressive_rate is not None and running_in_volume is not None and t_min.size:
        tt = np.linspace(0.0, float(np.nanmax(t_min)), 50)
        ax.plot(
            tt,
            (running_in_volume + progressive_rate * tt * 60.0) / UM3,
            '-',
            color='k',
            lw=1,
            label='running-in + progressive line',
        )
        vr = running_in_volume / UM3
        ax.axhline(vr, color='tab:green', ls=':', label=f'running-in {vr:.4g} um^3')
        w0, w1 = window_min
        ax.axvspan(w0, w1, color='0.85', alpha=0.5, label=f'{w0:g}-{w1:g} min window')
    ax.set_xlabel('test time [min]')
    ax.set_ylabel('wear volume [um^3]')
    ax.legend(fontsize=8, loc='upper left')
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=110, bbox_inches='tight')
    plt.close(fig)
    return Path(path)


def plot_campaign_kw(path: str | Path, rows: Sequence[Mapping[str, object]]) -> Path:
    """Plot Fig. 12: wear coefficients k_w [um^3/(N m)] of several runs against conditions.

    Progressive and running-in k_w against load [N], oil temperature [K], stroke
    [mm] and frequency [Hz]. ``rows``: one run summary each (keys of ``tribo wear``'s summary.json:
    ``load_N``, ``temperature_K``, ``stroke_m``, ``frequency_hz``, ``k_w_progressive``,
    ``k_w_running_in`` and their ``*_se``, ``sliding_distance_convention``).
    Returns ``path``.
    """
    fig, axes = plt.subplots(2, 2, figsize=(10, 7))
    panels = (
        ('load_N', 'load [N]', 1.0),
        ('temperature_K', 'oil temperature [K]', 1.0),
        ('stroke_m', 'stroke [mm]', 1e3),
        ('frequency_hz', 'frequency [Hz]', 1.0),
    )
    for ax, (key, label, scale) in zip(axes.flat, panels, strict=True):
        for kw, name, color in (
            ('k_w_progressive', 'progressive', 'C0'),
            ('k_w_running_in', 'running-in', 'C1'),
        ):
            have = [r for r in rows if r.get(key) is not None and r.get(kw) is not None]
            xs = [_num(r[key]) * scale for r in have]
            ys = [_num(r[kw]) for r in have]
            es = [_num(r.get(kw + '_se') or 0.0) for r in have]
            ax.errorbar(xs, ys, yerr=es, fmt='o', color=color, label=name, capsize=3)
        ax.set_xlabel(label)
        ax.set_ylabel('k_w [um^3/(N m)]')
        ax.grid(alpha=0.3)
    axes.flat[0].legend(fontsize=8)
    conv = {str(r.get('sliding_distance_convention')) for r in rows}
    fig.suptitle(f'Wear coefficients (Fig. 12 style; sliding distance: {", ".join(sorted(conv))})')
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return Path(path)


def _num(x: object) -> float:
    """Convert a summary.json number to float."""
    return float(x)  # type: ignore[arg-type]
