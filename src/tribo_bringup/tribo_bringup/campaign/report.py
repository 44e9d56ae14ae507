"""The campaign's HTML page: the paper's comparisons over every session of a store.

``OUT/index.html`` is one self-contained page (inline CSS, figures as base64
PNG; :mod:`tribo_bringup.report.page`) with:

- the sessions (status, metadata, error of a failed one);
- Fig. 4/5 per oil and drive speed (torsion moment envelope [N m], mu0 and
  mu_inf per block; :func:`tribo_estimation.plots.plot_campaign`);
- mu0 and mu_inf (Equ. 8) against the drive speed [rad/s] per oil, the mean of
  the session's good blocks with its standard error (block-to-block scatter /
  sqrt(n));
- the motion map: stick-slip / slip-slip / steady per block over drive speed
  and test time [s];
- Fig. 12: running-in and progressive k_w [um^3/(N m)] against load,
  temperature, stroke and frequency (:func:`tribo_nvct.plots.plot_campaign_kw`);
- the missing-physics verdict per session.

Everything is read from the store's views; the page is written atomically.
"""

from __future__ import annotations

import html
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .analyses import Cell
from .query import query

if TYPE_CHECKING:
    from tribo_bringup.report.page import Section

#: Colour of each motion type in the motion map.
MOTION_COLOURS = {'stick-slip': 'tab:red', 'slip-slip': 'tab:orange', 'steady': 'tab:blue'}
RPM = 60.0 / (2.0 * math.pi)

Record = dict[str, Cell]


def _rows(store: Path, sql: str) -> list[Record]:
    cols, rows = query(store, sql)
    return [dict(zip(cols, r, strict=True)) for r in rows]


def _num(v: Cell) -> float:
    return float(v) if isinstance(v, int | float) and not isinstance(v, bool) else math.nan


def build_report(store: str | Path, out: str | Path) -> Path:
    """Write the campaign page ``OUT/index.html`` from a store.

    Parameters
    ----------
    store : str or Path
        The store directory.
    out : str or Path
        Output directory (created; ``index.html`` replaced when complete).

    Returns
    -------
    Path
        The page.

    Raises
    ------
    CampaignError
        No store there.
    """
    from tribo_bringup.outputs import atomic_output_dir
    from tribo_bringup.report.page import render_html
    from tribo_bringup.report.provenance import provenance

    root = Path(store)
    sessions = _rows(root, 'SELECT * FROM sessions ORDER BY session_id')
    blocks = _rows(root, 'SELECT * FROM blocks')
    disc = _rows(root, 'SELECT * FROM discrepancy')
    wear = _rows(root, 'SELECT * FROM wear')
    by_id = {str(s['session_id']): s for s in sessions}
    speeds = _session_speeds(sessions, blocks)
    outdir = Path(out)
    with atomic_output_dir(outdir) as stage:
        sections: list[Section] = [_sessions_section(sessions)]
        if blocks:
            sections.append(_fig45_section(stage, blocks, by_id, speeds))
            sections.append(_speed_section(stage, blocks, by_id, speeds))
            sections.append(_motion_section(stage, blocks, speeds))
        if wear:
            sections.append(_wear_section(stage, wear))
        if disc:
            sections.append(_verdict_section(disc, by_id))
        n_ok = sum(1 for s in sessions if s.get('status') == 'ok')
        n_failed = sum(1 for s in sessions if s.get('status') == 'failed')
        summary = [
            f'{len(sessions)} sessions: {n_ok} ok, {n_failed} failed, '
            f'{len(sessions) - n_ok - n_failed} pending',
            f'{len(blocks)} friction blocks, {len(disc)} discrepancy verdicts, '
            f'{len(wear)} wear evaluations',
            f'store: {root.resolve()}',
        ]
        page = render_html(
            'Campaign report', summary, sections, provenance(['tribo', 'campaign', 'report'])
        )
        for f in stage.glob('*.png'):
            f.unlink()
        (stage / 'index.html').write_text(page, encoding='utf-8')
    return outdir / 'index.html'


def _oil(s: Mapping[str, Cell] | None) -> str:
    v = (s or {}).get('oil')
    return str(v) if v is not None else '-'


def _session_speeds(
    sessions: Sequence[Mapping[str, Cell]], blocks: Sequence[Mapping[str, Cell]]
) -> dict[str, float]:
    """Drive speed per session [rad/s]: metadata ``speed_rpm``, else the blocks' median w0."""
    w0: dict[str, list[float]] = {}
    for b in blocks:
        v = _num(b.get('w0'))
        if b.get('quality') == 'ok' and math.isfinite(v):
            w0.setdefault(str(b['session_id']), []).append(v)
    out: dict[str, float] = {}
    for s in sessions:
        sid = str(s['session_id'])
        rpm = _num(s.get('speed_rpm'))
        if math.isfinite(rpm):
            out[sid] = rpm / RPM
        elif w0.get(sid):
            out[sid] = float(np.median(w0[sid]))
    return out


def _sessions_section(sessions: Sequence[Mapping[str, Cell]]) -> Section:
    from tribo_bringup.report.page import Section, table

    skip = {'path', 'key', 'content_hash', 'file_size', 'file_mtime_ns', 'rig', 'nvct'}
    skip |= {'namespace', 'error_kind', 'analysed_at'}
    cols = [c for c in (sessions[0] if sessions else {}) if c not in skip]
    rows = [[s.get(c) for c in cols] for s in sessions]
    return Section('sessions', 'Sessions', table(rows, cols, 'sessions'))


def _block_table(rows: Sequence[Mapping[str, Cell]]) -> dict[str, np.ndarray]:
    """Column arrays of one session's blocks, as ``read_blocks_csv`` gives them."""
    from tribo_estimation.core.blockfit import FILE_COLUMNS

    out: dict[str, np.ndarray] = {}
    for c in FILE_COLUMNS:
        if c in ('motion', 'quality'):
            out[c] = np.array([str(r.get(c)) for r in rows], dtype=object)
        else:
            out[c] = np.array([_num(r.get(c)) for r in rows], dtype=float)
    return out


def _fig45_section(
    stage: Path,
    blocks: Sequence[Mapping[str, Cell]],
    by_id: Mapping[str, Mapping[str, Cell]],
    speeds: Mapping[str, float],
) -> Section:
    from tribo_bringup.report.page import Section, figure
    from tribo_estimation.plots import CampaignRun, plot_campaign

    per: dict[str, list[Mapping[str, Cell]]] = {}
    for b in blocks:
        per.setdefault(str(b['session_id']), []).append(b)
    order = sorted(per, key=lambda sid: (_oil(by_id.get(sid)), speeds.get(sid, math.nan), sid))
    runs = []
    for sid in order:
        w = speeds.get(sid, math.nan)
        label = f'{w * RPM:.0f} rpm ({sid})' if math.isfinite(w) else sid
        runs.append(CampaignRun(label, f'oil {_oil(by_id.get(sid))}', _block_table(per[sid])))
    body = figure(
        lambda p: plot_campaign(runs, p, 'friction per block, per oil and drive speed'),
        stage / 'fig45.png',
        'Fig. 4/5 per oil and drive speed: torsion moment max/min/mean [N m] above, '
        'mu0 and mu_inf per block (Equ. 8) below.',
    )
    return Section('fig45', 'Fig. 4/5: friction per oil and speed', body)


def speed_points(
    blocks: Sequence[Mapping[str, Cell]],
    by_id: Mapping[str, Mapping[str, Cell]],
    speeds: Mapping[str, float],
) -> dict[str, list[tuple[float, float, float, float, float]]]:
    """Return per oil: (drive speed [rad/s], mu0, SE, mu_inf, SE) of each session's good blocks.

    Parameters
    ----------
    blocks : sequence of mapping
        Rows of the ``blocks`` view.
    by_id : mapping
        Session rows by id (for the oil).
    speeds : mapping
        Drive speed per session [rad/s].

    Returns
    -------
    dict
        Oil -> points sorted by speed; the SE is the blocks' standard deviation
        over sqrt(n) (the largest block SE for a single block).
    """
    per: dict[str, list[Mapping[str, Cell]]] = {}
    for b in blocks:
        if b.get('quality') == 'ok':
            per.setdefault(str(b['session_id']), []).append(b)
    out: dict[str, list[tuple[float, float, float, float, float]]] = {}
    for sid, rows in per.items():
        w = speeds.get(sid, math.nan)
        if not math.isfinite(w):
            continue
        stats = []
        for name in ('mu0', 'mu_inf'):
            v = np.array([_num(r.get(name)) for r in rows])
            se = np.array([_num(r.get(f'{name}_se')) for r in rows])
            n = v.size
            spread = float(np.std(v, ddof=1) / math.sqrt(n)) if n > 1 else math.nan
            stats += [float(np.mean(v)), spread if n > 1 else float(np.nanmax(se))]
        out.setdefault(_oil(by_id.get(sid)), []).append((w, *stats))  # type: ignore[arg-type]
    return {k: sorted(v) for k, v in sorted(out.items())}


def _speed_section(
    stage: Path,
    blocks: Sequence[Mapping[str, Cell]],
    by_id: Mapping[str, Mapping[str, Cell]],
    speeds: Mapping[str, float],
) -> Section:
    from tribo_bringup.report.page import Section, figure, table

    pts = speed_points(blocks, by_id, speeds)

    def draw(path: Path) -> None:
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), sharex=True)
        for oil, p in pts.items():
            a = np.array(p, dtype=float)
            for ax, col in zip(axes, (1, 3), strict=True):
                ax.errorbar(a[:, 0], a[:, col], yerr=a[:, col + 1], marker='o', capsize=3,
                            label=f'oil {oil}')  # fmt: skip
        for ax, name in zip(axes, ('mu0', 'mu_inf'), strict=True):
            ax.set_xlabel('drive speed [rad/s]')
            ax.set_ylabel(f'{name} [-]')
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(path, dpi=90)
        plt.close(fig)

    rows = [[oil, *p] for oil, ps in pts.items() for p in ps]
    body = figure(
        draw,
        stage / 'speed.png',
        'mu0 and mu_inf (Equ. 8) against drive speed per oil: mean of the good blocks of '
        'each session, error bars one standard error.',
    ) + table(rows, ('oil', 'drive speed [rad/s]', 'mu0', 'mu0 SE', 'mu_inf', 'mu_inf SE'), 'speed')
    return Section('speed', 'mu0 and mu_inf against drive speed', body)


def _motion_section(
    stage: Path, blocks: Sequence[Mapping[str, Cell]], speeds: Mapping[str, float]
) -> Section:
    from tribo_bringup.report.page import Section, figure

    first: dict[str, float] = {}
    for b in blocks:
        sid = str(b['session_id'])
        first[sid] = min(first.get(sid, math.inf), _num(b.get('t_start')))

    def draw(path: Path) -> None:
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(8, 3.8))
        for motion, colour in MOTION_COLOURS.items():
            sel = [b for b in blocks if b.get('motion') == motion]
            x = [_num(b.get('t_start')) - first[str(b['session_id'])] for b in sel]
            y = [speeds.get(str(b['session_id']), math.nan) for b in sel]
            ax.scatter(x, y, s=18, marker='s', color=colour, label=motion)
        ax.set_xlabel('test time [s]')
        ax.set_ylabel('drive speed [rad/s]')
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc='upper right')
        fig.tight_layout()
        fig.savefig(path, dpi=90)
        plt.close(fig)

    body = figure(
        draw,
        stage / 'motion.png',
        'Motion type of every block (stick-slip, slip-slip, steady) over drive speed and '
        'test time since the session start.',
    )
    return Section('motion', 'Motion map: stick-slip, slip-slip, steady', body)


def _wear_section(stage: Path, wear: Sequence[Mapping[str, Cell]]) -> Section:
    from tribo_bringup.report.page import Section, figure, table
    from tribo_nvct.plots import plot_campaign_kw

    cols: tuple[str, ...] = ('session_id', 'load_N', 'temperature_K', 'stroke_m', 'frequency_hz')
    cols += ('k_w_running_in', 'k_w_running_in_se', 'k_w_progressive', 'k_w_progressive_se')
    body = figure(
        lambda p: plot_campaign_kw(p, wear),
        stage / 'fig12.png',
        'Fig. 12: running-in and progressive wear coefficients k_w [um^3/(N m)] against '
        'load, oil temperature, stroke and frequency.',
    ) + table([[w.get(c) for c in cols] for w in wear], cols, 'wear')
    return Section('wear', 'Fig. 12: wear coefficients', body)


def _verdict_section(
    disc: Sequence[Mapping[str, Cell]], by_id: Mapping[str, Mapping[str, Cell]]
) -> Section:
    from tribo_bringup.report.page import Section, table

    rows = [
        [d.get('session_id'), _oil(by_id.get(str(d.get('session_id')))), d.get('verdict'),
         d.get('finding')]
        for d in disc
    ]  # fmt: skip
    body = table(rows, ('session', 'oil', 'verdict', 'missing physics'), 'verdicts') + (
        '<p>' + html.escape('Torque residual RMS in N m; the effects named were tried on a '
                            'window of each session (settings discrepancy_*).') + '</p>'
    )  # fmt: skip
    return Section('verdicts', 'Missing physics per session', body)
