"""PNG plots of the discrepancy workflow (matplotlib, Agg backend, no display).

* ``residual_<localiser>.png``: torsion-moment residual (N m) before (baseline)
  and after (final model) against the localising variable of each added
  effect (binned mean and rms), or against time if nothing was added.
* ``traces.png``: measured vs simulated torsion moment and angular
  acceleration over a short window, baseline and final model.
* ``spectrum.png``: residual amplitude spectra before and after.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt
import numpy as np
from scipy import signal

from .localise import binned_for, torque_residual
from .stats import BinnedResidual, FloatArray

if TYPE_CHECKING:
    from .pipeline.result import MissingPhysics


def plot_binned(
    before: BinnedResidual, after: BinnedResidual, path: str | Path, *, title: str
) -> Path:
    """Binned residual mean and rms before/after against one variable."""
    p = Path(path)
    fig, ax = plt.subplots(figsize=(7.0, 4.0), dpi=100)
    for b, colour, label in ((before, 'tab:red', 'baseline'), (after, 'tab:blue', 'final')):
        if b.centres:
            ax.plot(b.centres, b.rms, 'o-', color=colour, label=f'{label} rms')
            ax.plot(b.centres, b.mean, 's--', color=colour, alpha=0.6, label=f'{label} mean')
    ax.axhline(0.0, color='k', lw=0.5)
    ax.set_xlabel(f'{before.variable} [{before.unit}]')
    ax.set_ylabel('torsion-moment residual [N m]')
    ax.set_title(title)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(p)
    plt.close(fig)
    return p


def plot_traces(
    time: FloatArray,
    measured: dict[str, FloatArray],
    baseline: dict[str, FloatArray],
    final: dict[str, FloatArray],
    path: str | Path,
    *,
    window: tuple[float, float],
) -> Path:
    """Measured vs simulated torsion moment (N m) and acceleration (rad/s^2)."""
    p = Path(path)
    sel = (time >= window[0]) & (time <= window[1])
    channels = [('torsion_moment', 'N m'), ('angular_acceleration', 'rad/s^2')]
    fig, axes = plt.subplots(len(channels) + 1, 2, figsize=(11.0, 8.0), dpi=100, sharex=True)
    for col, sim in enumerate((baseline, final)):
        ax = axes[len(channels), col]
        ax.plot(
            time[sel],
            measured['torsion_moment'][sel] - sim['torsion_moment'][sel],
            color='tab:red',
            lw=0.7,
        )
        ax.set_ylabel('torque residual [N m]')
        ax.set_xlabel('time [s]')
        ax.grid(alpha=0.3)
    for row, (ch, unit) in enumerate(channels):
        for col, (sim, label) in enumerate(((baseline, 'baseline'), (final, 'final'))):
            ax = axes[row, col]
            ax.plot(time[sel], measured[ch][sel], color='k', lw=0.8, label='measured')
            ax.plot(time[sel], sim[ch][sel], color='tab:orange', lw=0.8, label=f'{label} model')
            ax.set_ylabel(f'{ch} [{unit}]')
            ax.grid(alpha=0.3)
            if row == 0:
                ax.set_title(f'{label} model')
                ax.legend(fontsize=8, loc='upper right')
    fig.tight_layout()
    fig.savefig(p)
    plt.close(fig)
    return p


def plot_spectrum(before: FloatArray, after: FloatArray, fs: float, path: str | Path) -> Path:
    """Amplitude spectral density of the torque residual before/after (N m/sqrt(Hz))."""
    p = Path(path)
    fig, ax = plt.subplots(figsize=(7.0, 4.0), dpi=100)
    for r, colour, label in ((before, 'tab:red', 'baseline'), (after, 'tab:blue', 'final')):
        n = int(min(r.size, 8192))
        f, psd = signal.welch(r - np.mean(r), fs=fs, nperseg=n)
        ax.semilogy(f[1:], np.sqrt(psd[1:]), color=colour, lw=0.8, label=label)
    ax.set_xlim(0, min(fs / 2, 500.0))
    ax.set_xlabel('frequency [Hz]')
    ax.set_ylabel('residual ASD [N m/sqrt(Hz)]')
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(p)
    plt.close(fig)
    return p


def write_plots(result: MissingPhysics, out_dir: str | Path) -> list[Path]:
    """All PNG plots of the first record of a pipeline result into ``out_dir``.

    One ``residual_<localiser>.png`` per named effect (against the variable
    that effect explains), or ``residual_test_time.png`` and
    ``residual_phase.png`` when nothing was named; ``traces.png`` (a 0.25 s
    window in the middle of the record) and ``spectrum.png``.
    """
    from . import candidates as cand_lib

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if not result.traces:
        return []
    tr = result.traces[0]
    pb = tr.problem
    r0 = torque_residual(pb, tr.baseline)
    r1 = torque_residual(pb, tr.final)
    paths: list[Path] = []
    names = [cand_lib.get(e.form).localiser for e in result.named] or ['test_time', 'phase']
    done: set[str] = set()
    for name in names:
        var = 'test_time' if name == 'spectrum' else name
        if var in done:
            continue
        done.add(var)
        b0 = binned_for(var, pb, tr.baseline, r0)
        b1 = binned_for(var, pb, tr.final, r1)
        effects = ', '.join(result.added) or 'none named'
        paths.append(
            plot_binned(b0, b1, out / f'residual_{var}.png', title=f'residual vs {var} ({effects})')
        )
    t = pb.record.time
    mid = 0.5 * (t[0] + t[-1])
    measured = {
        'torsion_moment': pb.record.torsion_moment,
        'angular_acceleration': pb.record.angular_acceleration,
    }
    sims = []
    for sim in (tr.baseline, tr.final):
        sims.append(
            {
                'torsion_moment': sim.torsion_moment,
                'angular_acceleration': sim.angular_acceleration,
            }
        )
    paths.append(
        plot_traces(t, measured, sims[0], sims[1], out / 'traces.png', window=(mid, mid + 0.25))
    )
    cov0, cov1 = tr.baseline.covered, tr.final.covered
    paths.append(plot_spectrum(r0[cov0], r1[cov1], pb.record.fs, out / 'spectrum.png'))
    return paths
