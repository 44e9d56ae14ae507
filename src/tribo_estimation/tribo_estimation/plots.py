"""Figures of the block-wise friction estimation (paper section 2.5, Fig. 4-6).

All functions draw with the non-interactive Agg backend into PNG files and
take plain arrays, so they serve the CLI (``tribo friction``,
``tribo campaign``) and reports alike. Block tables are mappings from the
``blocks.csv`` column names to arrays (see
:func:`tribo_estimation.core.blockfit.read_blocks_csv`).

Flagged blocks (quality other than ``ok``) are drawn as grey crosses and
labelled as flagged: they are never shown as good estimates.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import matplotlib

matplotlib.use('Agg')

import matplotlib.pyplot as plt
import numpy as np
import numpy.typing as npt
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from tribo_estimation.core.blockfit.figdata import DetailTrace, time_origin
from tribo_estimation.core.record import RigRecord
from tribo_estimation.core.signal import runs
from tribo_estimation.errors import InvalidDataError

FloatArray = npt.NDArray[np.float64]
BlockTable = Mapping[str, np.ndarray]

_C_MU0 = 'tab:red'
_C_MUINF = 'tab:blue'
_C_FLAG = '0.6'


def _good_mask(table: BlockTable) -> npt.NDArray[np.bool_]:
    q = np.asarray(table['quality'], dtype=object)
    return np.array([str(v) == 'ok' for v in q], dtype=bool)


def _time_axis(table: BlockTable) -> tuple[FloatArray, str]:
    """Return the block mid times [s], or [min] for runs longer than 10 min, and the label.

    Times count from the first block when they are wall-clock stamps.
    """
    t = 0.5 * (np.asarray(table['t_start'], float) + np.asarray(table['t_end'], float))
    origin = time_origin(float(np.nanmin(t))) if t.size else 0.0
    since = ' since first block' if origin else ''
    t = t - origin
    if t.size and np.nanmax(t) - np.nanmin(t) > 600.0:
        return t / 60.0, f'time{since} [min]'
    return t, f'time{since} [s]'


def _draw_moment(ax: Axes, table: BlockTable, x: FloatArray) -> None:
    ax.plot(x, np.asarray(table['moment_max'], float), color='tab:orange', lw=1.0, label='max')
    ax.plot(x, np.asarray(table['moment_mean'], float), color='k', lw=1.0, label='mean')
    ax.plot(x, np.asarray(table['moment_min'], float), color='tab:green', lw=1.0, label='min')
    ax.set_ylabel('torsion moment $C_1\\varphi_1$ [N m]')
    ax.grid(True, alpha=0.3)


def _draw_mu(ax: Axes, table: BlockTable, x: FloatArray, errorbars: bool = True) -> None:
    good = _good_mask(table)
    bad = ~good
    for key, se_key, color, label in (
        ('mu0', 'mu0_se', _C_MU0, '$\\mu_0$'),
        ('mu_inf', 'mu_inf_se', _C_MUINF, '$\\mu_\\infty$'),
    ):
        y = np.asarray(table[key], float)
        se = np.asarray(table[se_key], float)
        if errorbars and good.sum() <= 400:
            ax.errorbar(
                x[good],
                y[good],
                yerr=np.where(np.isfinite(se[good]), se[good], 0.0),
                fmt='.',
                ms=3,
                color=color,
                lw=0.6,
                label=label,
            )
        else:
            ax.plot(x[good], y[good], '.', ms=3, color=color, label=label)
        if bad.any():
            ax.plot(x[bad], y[bad], 'x', ms=3, color=_C_FLAG)
    if bad.any():
        ax.plot([], [], 'x', ms=3, color=_C_FLAG, label='flagged block')
    ax.set_ylabel('friction coefficient [-]')
    ax.grid(True, alpha=0.3)


def _save(fig: Figure, path: str | os.PathLike[str]) -> None:
    fig.savefig(os.fspath(path), dpi=120)
    plt.close(fig)


def plot_blocks(
    table: BlockTable, path: str | os.PathLike[str], title: str = ''
) -> tuple[int, int]:
    """Plot the blocks in the layout of the paper's Fig. 4/5.

    Upper panel: torsion moment max/min/mean per block [N m]; lower panel: mu0
    and mu_inf per block (Equ. 8) with standard errors.

    Returns
    -------
    tuple[int, int]
        The numbers of good and of flagged blocks drawn.
    """
    x, xlabel = _time_axis(table)
    fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(8, 6))
    _draw_moment(ax1, table, x)
    ax1.legend(loc='upper right', fontsize=8)
    _draw_mu(ax2, table, x)
    ax2.legend(loc='upper right', fontsize=8)
    ax2.set_xlabel(xlabel)
    if title:
        ax1.set_title(title)
    fig.tight_layout()
    _save(fig, path)
    good = _good_mask(table)
    return int(good.sum()), int((~good).sum())


def stribeck(v: FloatArray, mu0: float, mu_inf: float, k: float) -> FloatArray:
    """Paper Equ. 8: mu(|v|) = (mu0 - mu_inf) exp(-k |v|) + mu_inf (v in rad/s, k in s/rad)."""
    return (mu0 - mu_inf) * np.exp(-k * np.abs(v)) + mu_inf


def plot_mu_slip(
    table: BlockTable,
    path: str | os.PathLike[str],
    k: float | FloatArray,
    slip_speed: FloatArray | None = None,
    mu_samples: FloatArray | None = None,
    n_curves: int = 6,
    title: str = '',
) -> None:
    """Plot the friction coefficient against slip speed [rad/s].

    Fitted Stribeck curves (Equ. 8) of up to ``n_curves`` good blocks spread over
    the run, and the observer's samples mu = |M| / (F_N R) against |v| as points.
    """
    fig, ax = plt.subplots(figsize=(7, 5))
    if slip_speed is not None and mu_samples is not None and len(slip_speed):
        ax.plot(np.abs(slip_speed), mu_samples, '.', ms=1.5, color='0.45', alpha=0.4)
        ax.plot([], [], '.', color='0.5', label='observer samples')
    good = np.flatnonzero(
        _good_mask(table)
        & np.isfinite(np.asarray(table['mu0'], float))
        & np.isfinite(np.asarray(table['mu_inf'], float))
    )
    vmax = 3.0
    if slip_speed is not None and len(slip_speed):
        vmax = float(max(1.0, np.nanpercentile(np.abs(slip_speed), 99.5)))
    v = np.linspace(0.0, vmax, 200)
    ks = np.broadcast_to(np.asarray(k, float), np.asarray(table['mu0']).shape)
    starts = np.asarray(table['t_start'], float)
    origin = time_origin(float(np.nanmin(starts))) if starts.size else 0.0
    if good.size:
        pick = good[np.unique(np.linspace(0, good.size - 1, min(n_curves, good.size)).astype(int))]
        cmap = plt.get_cmap('viridis')
        for j, i in enumerate(pick):
            c = cmap(j / max(1, len(pick) - 1))
            mu = stribeck(v, float(table['mu0'][i]), float(table['mu_inf'][i]), float(ks[i]))
            t_block = float(table['t_start'][i]) - origin
            ax.plot(v, mu, color=c, lw=1.5, label=f'block at {t_block:.0f} s')
    ax.set_xlabel('slip speed $|\\omega_2-\\omega_1|$ [rad/s]')
    ax.set_ylabel('friction coefficient $\\mu$ [-]')
    ax.set_xlim(0.0, vmax)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title)
    fig.tight_layout()
    _save(fig, path)


def plot_record(record: RigRecord, path: str | os.PathLike[str], title: str = '') -> None:
    """Plot a record's channels over time: torsion moment, chamber acceleration, shaft speed.

    Replaced samples (spikes, bursts of the input checks) are marked in red.

    Parameters
    ----------
    record : RigRecord
        The record (time [s], torsion moment [N m], acceleration [rad/s^2], speed [rad/s]).
    path : str or PathLike
        The PNG file.
    title : str
        Figure title.
    """
    fig, axes = plt.subplots(3, 1, figsize=(8, 7), sharex=True)
    rep = record.replaced
    for ax, name, label in zip(
        axes,
        ('torsion_moment', 'angular_acceleration', 'speed'),
        (
            'torsion $C_1\\varphi_1$ [N m]',
            "chamber $\\omega_1'$ [rad/s$^2$]",
            'shaft $\\omega_2$ [rad/s]',
        ),
        strict=True,
    ):
        y = record.channel(name)
        ax.plot(record.time, y, color='k', lw=0.6)
        if rep.any():
            ax.plot(record.time[rep], y[rep], '.', color='tab:red', ms=3, label='replaced')
            ax.legend(fontsize=7, loc='upper right')
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel('time [s]')
    if title:
        axes[0].set_title(title)
    fig.tight_layout()
    _save(fig, path)


def _stick_spans(time: FloatArray, stick: npt.NDArray[np.bool_]) -> list[tuple[float, float]]:
    starts, stops = runs(stick)
    ends = stops - 1
    dt = float(time[1] - time[0]) if time.size > 1 else 0.0
    return [(float(time[a]), float(time[b]) + dt) for a, b in zip(starts, ends, strict=True)]


def plot_detail(traces: Sequence[DetailTrace], path: str | os.PathLike[str]) -> None:
    """Plot the torsion moment [N m] over a short window, as the paper's Fig. 6.

    The stick phases are shaded; one panel per trace (e.g. stick-slip above,
    slip-slip below).
    """
    n = max(1, len(traces))
    fig, axes = plt.subplots(n, 1, figsize=(8, 3.0 * n), squeeze=False)
    for ax, tr in zip(axes[:, 0], traces, strict=False):
        for a, b in _stick_spans(tr.time, tr.stick):
            ax.axvspan(a, b, color='tab:cyan', alpha=0.3, lw=0)
        ax.plot(tr.time, tr.torsion, color='k', lw=0.8, label='torsion $C_1\\varphi_1$ (measured)')
        if np.isfinite(tr.moment).any():
            ax.plot(
                tr.time, tr.moment, color='tab:purple', lw=0.8, label='friction moment (observer)'
            )
        if np.isfinite(tr.simulated).any():
            ax.plot(
                tr.time, tr.simulated, '--', color='tab:red', lw=0.8, label='torsion (fitted model)'
            )
        ax.plot([], [], 's', color='tab:cyan', alpha=0.3, label='sticking')
        ax.set_title(tr.title, fontsize=10)
        ax.set_ylabel('moment [N m]')
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, loc='upper right')
    axes[-1, 0].set_xlabel('time [s]')
    if not traces:
        axes[0, 0].text(0.5, 0.5, 'no block to show', ha='center', va='center')
    fig.tight_layout()
    _save(fig, path)


@dataclass(frozen=True)
class CampaignRun:
    """One run of a campaign: its label (e.g. "10 rpm"), group (e.g. "oil A") and block table."""

    label: str
    group: str
    table: BlockTable


def plot_campaign(
    runs: Sequence[CampaignRun], path: str | os.PathLike[str], title: str = ''
) -> tuple[int, int]:
    """Plot several runs side by side, as the paper's Fig. 4 (oil "A") vs Fig. 5 (oil "B").

    One column per run of a group, two rows per group (torsion moment envelope
    [N m] above, mu0/mu_inf below), shared axes so runs compare at a glance.

    Returns
    -------
    tuple[int, int]
        The grid drawn (rows, columns).
    """
    if not runs:
        raise InvalidDataError('campaign: no runs to plot')
    groups: list[str] = []
    for r in runs:
        if r.group not in groups:
            groups.append(r.group)
    per_group = {g: [r for r in runs if r.group == g] for g in groups}
    ncol = max(len(v) for v in per_group.values())
    nrow = 2 * len(groups)
    fig, axes = plt.subplots(
        nrow, ncol, figsize=(3.6 * ncol, 2.6 * nrow), squeeze=False, sharey='row'
    )
    mom_axes: list[Axes] = []
    mu_axes: list[Axes] = []
    for gi, g in enumerate(groups):
        for ci in range(ncol):
            ax_m, ax_mu = axes[2 * gi, ci], axes[2 * gi + 1, ci]
            if ci >= len(per_group[g]):
                ax_m.set_visible(False)
                ax_mu.set_visible(False)
                continue
            r = per_group[g][ci]
            x, xlabel = _time_axis(r.table)
            _draw_moment(ax_m, r.table, x)
            _draw_mu(ax_mu, r.table, x, errorbars=False)
            head = f'{g}: {r.label}' if g else r.label
            ax_m.set_title(head, fontsize=10)
            ax_mu.set_xlabel(xlabel)
            if ci > 0:
                ax_m.set_ylabel('')
                ax_mu.set_ylabel('')
            mom_axes.append(ax_m)
            mu_axes.append(ax_mu)
    if mom_axes:
        mom_axes[0].legend(fontsize=7, loc='upper right')
    if mu_axes:
        mu_axes[0].legend(fontsize=7, loc='upper right')
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    _save(fig, path)
    return nrow, ncol
