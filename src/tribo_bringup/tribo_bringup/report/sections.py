"""Sections of the session report.

Session, rig, friction per block (Fig. 4/5) with the motion detail (Fig. 6),
live nVCT wear (Fig. 10/11), the offline analyses, and the five-line summary.

Every section function fills its part of ``results`` (results.json; SI units, keys
name the unit where it is not SI) and returns the HTML; figures are written into
the report directory and embedded.
"""

from __future__ import annotations

import html
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from tribo_bringup import bridge_core as bc
from tribo_bringup.errors import BagError
from tribo_estimation.errors import EstimationError

from .analyses import AnalysisOutcome
from .page import (
    Section,
    as_float,
    as_int,
    as_list,
    as_mapping,
    as_opt_float,
    embed_png,
    figure,
    finite,
    fmt,
    json_html,
    kv,
    table,
    unavailable,
    write_csv,
)
from .scan import BagScan, read_rig_window, stick_flags

if TYPE_CHECKING:
    from tribo_estimation.core.blockfit.figdata import DetailTrace
    from tribo_estimation.core.model import RigParams
    from tribo_nvct.core.config import NvctConfig

NS = 1_000_000_000
DETAIL_S = 0.25  # length of the Fig. 6 detail windows [s]
UM3 = 1e-18  # m^3 per um^3 (display unit of wear volumes)

#: Rig parameters with unit and meaning (RIG.yaml, docs/ARCHITECTURE.md).
RIG_UNITS: dict[str, tuple[str, str]] = {
    'I1': ('kg m^2', 'chamber inertia'),
    'K1': ('N m s/rad', 'chamber viscous damping'),
    'C1': ('N m/rad', 'torsion element stiffness'),
    'I2': ('kg m^2', 'drive shaft inertia'),
    'K2': ('N m s/rad', 'drive viscous damping'),
    'C2': ('N m/rad', 'drive stiffness'),
    'F_N': ('N', 'normal force'),
    'R': ('m', 'effective friction radius'),
    'mu0': ('-', 'static friction coefficient (Equ. 8)'),
    'mu_inf': ('-', 'asymptotic friction coefficient (Equ. 8)'),
    'k': ('s/rad', 'Stribeck decay constant (Equ. 8)'),
    'nominal_speed': ('rad/s', 'nominal drive speed w0'),
    'ramp_time': ('s', 'start-up ramp of the drive'),
    'noise_torque': ('N m', 'torsion moment noise'),
    'noise_accel': ('rad/s^2', 'acceleration noise'),
    'noise_speed': ('rad/s', 'speed noise'),
}


def rig_section(
    rig: Mapping[str, object], rig_path: str | None, results: dict[str, object]
) -> Section:
    """Render the rig parameters used (RIG.yaml) and fill ``results['rig']``."""
    title = 'Rig parameters used'
    if not rig:
        results['rig'] = None
        return unavailable('rig', title, 'no RIG.yaml given (--rig)')
    params = {k: rig[k] for k in RIG_UNITS if k in rig}
    effects = as_mapping(rig.get('effects') or {})
    results['rig'] = {'file': rig_path, 'params': params, 'effects': dict(effects)}
    rows = [(k, as_float(v), RIG_UNITS[k][0], RIG_UNITS[k][1]) for k, v in params.items()]
    body = f'<p>From <code>{html.escape(str(rig_path))}</code>.</p>'
    body += table(rows, ('parameter', 'value', 'unit', 'meaning'), 'rig-params', digits=6)
    if effects:
        body += '<p>Hidden model extensions switched on in the simulated rig: '
        body += ', '.join(
            f'<code>{html.escape(k)} = {fmt(as_float(v))}</code>' for k, v in effects.items()
        )
        body += '</p>'
    return Section('rig', title, body)


def session_section(bag: Path, scan: BagScan, results: dict[str, object], out: Path) -> Section:
    """Render the session overview (bag, duration [s], streams and their gaps)."""
    duration = (scan.t_last_ns - scan.t_first_ns) / NS
    missing = sum(s.missing for s in scan.streams)
    streams: list[dict[str, object]] = [
        {
            'topic': s.topic,
            'first_index': s.first_index,
            'messages': s.messages,
            'samples': s.samples,
            'missing': s.missing,
            'gaps': s.gaps,
            'duplicates': s.duplicates,
        }
        for s in scan.streams
    ]
    results['session'] = {
        'bag': str(bag),
        'duration_s': duration,
        'messages': dict(sorted(scan.counts.items())),
        'missing_samples': missing,
        'truncated': scan.truncated or None,
        'streams': streams,
    }
    write_csv(
        out / 'streams.csv',
        streams,
        ('topic', 'first_index', 'messages', 'samples', 'missing', 'gaps', 'duplicates'),
    )
    body = kv(
        {'recorded duration': duration, 'missing samples (all streams)': missing},
        'session-summary',
        {'recorded duration': 's', 'missing samples (all streams)': 'samples'},
    )
    rows = [
        (s.topic, s.first_index, s.messages, s.samples, s.missing, s.gaps, s.duplicates)
        for s in scan.streams
    ]
    body += table(
        rows,
        ('stream', 'first index', 'blocks', 'samples', 'missing', 'gaps', 'duplicates'),
        'streams',
    )
    rows2 = sorted(scan.counts.items())
    body += table(rows2, ('topic', 'messages'), 'topics')
    if scan.truncated:
        body += f'<p class="warn">{html.escape(scan.truncated)}</p>'
    return Section('session', f'Session: {bag.name}', body)


FRICTION_COLUMNS = (
    't_start', 't_end', 'first_index', 'mu0', 'mu0_se', 'mu_inf', 'mu_inf_se', 'k',
    'moment_min', 'moment_max', 'moment_mean', 'motion', 'n_sticks', 'stick_fraction',
    'rms_residual', 'quality',
)  # fmt: skip


def block_table(ests: Sequence[Mapping[str, object]]) -> dict[str, np.ndarray]:
    """Convert estimates to a block table: ``blocks.csv`` column -> array (None -> NaN).

    The table is the input of :mod:`tribo_estimation.plots`.
    """
    from tribo_estimation.core.blockfit import CSV_COLUMNS

    table: dict[str, np.ndarray] = {}
    for c in CSV_COLUMNS:
        if bc.FRICTION_FIELDS[c][0] == 'string':
            table[c] = np.array([str(e[c]) for e in ests], dtype=object)
        else:
            table[c] = np.array([np.nan if e[c] is None else e[c] for e in ests], dtype=float)
    return table


def detail_trace(
    bag: Path, est: Mapping[str, object], t_ref: float, rig: RigParams | None, seconds: float
) -> DetailTrace | None:
    """Read the Fig. 6 trace: ``seconds`` [s] of torsion moment [N m] from block ``est``.

    The stick phases come from the core detection (:func:`stick_flags`, run over
    the whole block as the friction fit does; none without rig parameters). Time
    axis [s] from ``t_ref``, the first block's start. None when the bag has no rig
    samples there.
    """
    from tribo_estimation.core.blockfit.figdata import DetailTrace

    t_start = as_float(est['t_start'])
    span = as_float(est['t_end']) - t_start if est.get('t_end') is not None else seconds
    win = read_rig_window(bag, as_int(est['first_index']), min(max(span, seconds), 5.0))
    if win is None:
        return None
    stick = stick_flags(win, rig) if rig is not None else np.zeros(win.torsion.size, bool)
    n = min(win.torsion.size, max(1, round(seconds * win.sample_rate)))
    t0 = t_start - t_ref
    nan = np.full(n, np.nan)
    title = f'{est["motion"]} block at t = {t0:.0f} s'
    return DetailTrace(
        title, t0 + np.arange(n) / win.sample_rate, win.torsion[:n], nan, nan, stick[:n]
    )


def friction_section(
    ests: Sequence[Mapping[str, object]],
    source: str,
    results: dict[str, object],
    out: Path,
    bag: Path,
    rig: RigParams | None,
    rig_note: str = '',
) -> list[Section]:
    """Per-block friction table, Fig. 4/5 and Fig. 6 style plots (paper 2.5, Equ. 8).

    ``rig``: parameters for the stick detection of the Fig. 6 detail (None: no stick
    phases drawn, ``rig_note`` says why). Figures are written into ``out`` and embedded.
    """
    title = f'Friction per block ({source})'
    if not ests:
        results['friction'] = None
        return [
            unavailable(
                'friction',
                'Friction per block',
                'no /friction/estimate messages in the bag and no offline fit result',
            )
        ]
    write_csv(out / 'friction_blocks.csv', ests, FRICTION_COLUMNS)
    good = [e for e in ests if e['quality'] == 'ok']
    mu0 = finite(as_opt_float(e['mu0']) for e in good)
    muinf = finite(as_opt_float(e['mu_inf']) for e in good)
    motions: dict[str, int] = {}
    for e in good:
        motion = str(e['motion'])
        motions[motion] = motions.get(motion, 0) + 1
    summary: dict[str, object] = {
        'blocks': len(ests),
        'blocks_ok': len(good),
        'mu0_min': float(mu0.min()) if mu0.size else None,
        'mu0_max': float(mu0.max()) if mu0.size else None,
        'mu0_mean': float(mu0.mean()) if mu0.size else None,
        'mu_inf_min': float(muinf.min()) if muinf.size else None,
        'mu_inf_max': float(muinf.max()) if muinf.size else None,
        'mu_inf_mean': float(muinf.mean()) if muinf.size else None,
        'motion_types': motions,
        'stick_fraction_mean': float(
            np.mean(finite(as_opt_float(e['stick_fraction']) for e in good))
        )
        if good
        else None,
    }
    summary['source'] = source
    results['friction'] = summary
    body = kv(
        {k: v for k, v in summary.items() if k not in ('motion_types', 'source')},
        'friction-summary',
    )
    body += (
        '<p>Motion types of the good blocks: '
        + (', '.join(f'{html.escape(k)}: <b>{v}</b>' for k, v in sorted(motions.items())) or 'none')
        + '</p>'
    )
    from tribo_estimation.plots import plot_blocks, plot_detail

    body += figure(
        lambda p: plot_blocks(block_table(ests), p, title=f'friction per block ({source})'),
        out / 'friction_blocks.png',
        'Fig. 4/5 style: torsion moment max/mean/min per block (top), mu0 and mu_inf per '
        'block with +-1 SE (bottom); flagged blocks grey crosses',
    )
    rows = [
        (
            as_float(e['t_start']) - as_float(ests[0]['t_start']),
            e['mu0'],
            e['mu0_se'],
            e['mu_inf'],
            e['mu_inf_se'],
            e['motion'],
            e['n_sticks'],
            e['stick_fraction'],
            e['quality'],
        )
        for e in ests
    ]
    body += '<details open><summary>Per-block table (friction_blocks.csv)</summary>'
    body += table(
        rows,
        (
            't [s]',
            'mu0',
            'mu0 SE',
            'mu_inf',
            'mu_inf SE',
            'motion',
            'sticks',
            'stick fraction',
            'quality',
        ),
        'friction-blocks',
    )
    body += '</details>'
    sections = [Section('friction', title, body)]
    # Fig. 6: one stick-slip and one slip-slip block in detail (0.25 s each)
    picks: list[Mapping[str, object]] = []
    for motion in ('stick-slip', 'slip-slip'):
        cand = [e for e in good if e['motion'] == motion]
        if cand:
            picks.append(cand[len(cand) // 2])
    details: list[DetailTrace] = []
    reasons: list[str] = []
    for e in picks:
        if e.get('first_index') is None:
            continue
        try:
            d = detail_trace(bag, e, as_float(ests[0]['t_start']), rig, DETAIL_S)
        except (BagError, EstimationError) as exc:
            reasons.append(f'{e["motion"]} block: {exc}')
            continue
        if d is None:
            reasons.append(f'{e["motion"]} block: no aligned /rig/* samples in the bag there')
        else:
            details.append(d)
    if details:
        how = (
            'stick phases (shaded) from the stick detection of the friction analysis'
            if rig is not None
            else f'no stick phases: {rig_note}'
        )
        img = figure(
            lambda p: plot_detail(details, p),
            out / 'motion_detail.png',
            f'Torsion moment C1*phi1 over {DETAIL_S:g} s from the block start; {how}',
        )
        sections.append(Section('detail', 'Motion detail (Fig. 6 style)', img))
    elif reasons:
        sections.append(unavailable('detail', 'Motion detail (Fig. 6 style)', '; '.join(reasons)))
    return sections


def wear_section(
    scan: BagScan, nvct: NvctConfig | None, results: dict[str, object], out: Path
) -> Section:
    """Live wear states; ``nvct`` is the run's NvctConfig (k_w, window) or None."""
    title = 'nVCT wear (live wear monitor, /nvct/wear)'
    ws = scan.wear
    if not ws:
        results['wear'] = None
        return unavailable('wear', title, 'no /nvct/wear messages in the bag')
    cols = ('t', *[k for k in bc.WEAR_FIELDS if k != 't'])
    write_csv(out / 'wear_states.csv', ws, cols)
    last = ws[-1]
    summary: dict[str, Any] = {
        'dwells': len(ws),
        'test_time_s': last['t'],
        'wear_volume_m3': last['wear_volume'],
        'wear_volume_se_m3': last['wear_volume_se'],
        'wear_height_m': last['wear_height'],
        'wear_rate_m3_per_s': last['wear_rate'],
        'running_in_volume_m3': last['running_in_volume'],
        'progressive_rate_m3_per_s': last['progressive_rate'],
        'progressive_rate_se_m3_per_s': last['progressive_rate_se'],
    }
    kw = None
    if nvct is not None and last['progressive_rate'] is not None:
        # Equ. 10: k_w = (dV/dt) / (L * d_s per second), d_s by the configured convention
        kw = last['progressive_rate'] / (nvct.load * nvct.sliding_distance(1.0))
    summary['k_w_progressive_m3_per_N_m'] = kw
    summary['k_w_sliding_distance'] = nvct.sliding_convention if nvct is not None else None
    results['wear'] = summary
    units = {
        'test_time_s': 's', 'wear_volume_m3': 'm^3', 'wear_volume_se_m3': 'm^3',
        'wear_height_m': 'm', 'wear_rate_m3_per_s': 'm^3/s', 'running_in_volume_m3': 'm^3',
        'progressive_rate_m3_per_s': 'm^3/s', 'progressive_rate_se_m3_per_s': 'm^3/s',
        'k_w_progressive_m3_per_N_m': 'm^3/(N m)',
    }  # fmt: skip
    body = kv(summary, 'wear-summary', units)
    w0, w1 = (w / 60.0 for w in (nvct.window_s if nvct is not None else (7200.0, 10800.0)))
    from tribo_nvct.plots import plot_wear_states

    def col(name: str) -> np.ndarray:
        return np.array([np.nan if w[name] is None else w[name] for w in ws], dtype=float)

    body += figure(
        lambda p: plot_wear_states(
            p,
            col('t'),
            col('wear_volume'),
            col('wear_volume_se'),
            last['running_in_volume'],
            last['progressive_rate'],
            (w0, w1),
        ),
        out / 'wear_states.png',
        'Fig. 10/11 style: wear volume over test time (+-2 SE band), '
        f'progressive wear line (slope {w0:g}-{w1:g} min) and running-in volume',
    )
    return Section('wear', title, body)


def monitor_section(scan: BagScan, results: dict[str, object], out: Path) -> Section | None:
    """Render the live model monitor's windows (/model/discrepancy); None if the bag has none.

    One row per message: end time from the first window [s], baseline mu0/mu_inf
    (Equ. 8), torsion residual rms and noise floor [N m] and their ratio, where the
    residual concentrates, the named family or the best partial explanation with its
    fitted values, the rms with it [N m], whether the window names it (it alone explains
    the window down to the noise), the verdict in one line, the processing time [s] and
    the quality flags. A window whose time budget ended before every family was
    screened (``incomplete``) has a second message, its investigation (flag
    ``investigation``, every family screened): results.json counts windows and
    investigations apart; the names and partial explanations count both.
    """
    ws = scan.monitor
    if not ws:
        results['monitor'] = None
        return None
    cols = (
        't_start',
        't_end',
        *[k for k in bc.DISCREPANCY_FIELDS if k not in ('t_start', 't_end')],
    )
    write_csv(out / 'monitor_windows.csv', ws, (*cols, 'params'))
    # per family: the windows that name it, and those where it is the best partial explanation
    named: dict[str, int] = {}
    partial: dict[str, int] = {}
    for w in ws:
        if w['candidate']:
            counts = named if w['identifiable'] else partial
            counts[w['candidate']] = counts.get(w['candidate'], 0) + 1
    inquiries = [w for w in ws if 'investigation' in str(w['quality'] or '')]
    windows = [w for w in ws if 'investigation' not in str(w['quality'] or '')]
    times = [w['processing_time'] for w in windows if w['processing_time'] is not None]
    results['monitor'] = {
        'windows': len(windows),
        'investigations': len(inquiries),
        'named': named,
        'partial': partial,
        'processing_time_max_s': max(times) if times else None,
        'processing_time_median_s': float(np.median(times)) if times else None,
    }
    t0 = ws[0]['t_end'] or 0.0
    rows = [
        (
            (w['t_end'] or 0.0) - t0,
            w['mu0'],
            w['mu_inf'],
            w['residual_rms'],
            w['noise_floor'],
            w['ratio'],
            f'{w["concentration"]} ({fmt(w["concentration_share"], 2)})',
            w['candidate'] or '-',
            w['params'] or '-',
            w['candidate_rms'],
            w['identifiable'],
            w['identifiable_reason'],
            w['processing_time'],
            w['quality'] or '-',
        )
        for w in ws
    ]
    header = (
        'window end - first [s]', 'mu0 [-]', 'mu_inf [-]', 'residual rms [N m]',
        'noise floor [N m]', 'ratio [-]', 'concentrates in (share)', 'best candidate',
        'fitted', 'rms with it [N m]', 'named', 'verdict', 'processing [s]', 'quality',
    )  # fmt: skip
    body = (
        f"<p>{len(windows)} windows of the live model monitor: the paper's model (Equ. 1-8) "
        'fitted over a rolling window of the rig streams, its residual against the noise '
        'floor, where the residual concentrates and the verdict of the missing-physics '
        'pipeline (live budget): the family it names or the best partial explanation. '
        f'Investigations ({len(inquiries)}): windows whose budget ended before every effect '
        'family was screened (quality <code>incomplete</code>), screened again with every '
        'family (quality <code>investigation</code>, published when done). '
        'Windows as CSV: <code>monitor_windows.csv</code>.</p>'
    )
    body += table(rows, header, 'monitor-windows')
    return Section('monitor', 'Live model monitor (/model/discrepancy)', body)


def analysis_section(res: AnalysisOutcome, title: str) -> Section:
    """Render an offline analysis: what it called, its finding, numbers, figures and files."""
    if not res.ok:
        return unavailable(res.key, title, res.reason or 'not run')
    body = f'<p>Library call: <code>{html.escape(res.what)}</code> '
    body += f'({res.seconds:.1f} s). Outputs in <code>{html.escape(res.directory)}</code>.</p>'
    if res.note:
        body += f'<p class="note">{html.escape(res.note)}</p>'
    if res.finding:
        body = (
            f'<p class="finding" id="{res.key}-finding">Finding: '
            f'{html.escape(res.finding)}.</p>' + body
        )
    if res.summary:
        body += f'<details><summary>{html.escape(res.key)} results</summary>'
        body += json_html(res.summary) + '</details>'
    root = Path(res.directory)
    for png in res.figures:
        body += embed_png(png, str(root / png.name))
    if res.files:
        body += (
            '<p>Result files: '
            + ', '.join(f'<code>{html.escape(str(root / f.name))}</code>' for f in res.files)
            + '</p>'
        )
    return Section(res.key, title, body)


def summary_lines(results: Mapping[str, object]) -> list[str]:
    """Tell the story of the session in five lines (used by the page and ``tribo demo``)."""
    lines: list[str] = []
    if results.get('friction'):
        fr = as_mapping(results['friction'])
        lines.append(
            f'Friction: {fr["blocks_ok"]} of {fr["blocks"]} blocks fitted; mu0 '
            f'{fmt(fr["mu0_min"], 3)}..{fmt(fr["mu0_max"], 3)}, mu_inf '
            f'{fmt(fr["mu_inf_min"], 3)}..{fmt(fr["mu_inf_max"], 3)}'
        )
        mt = as_mapping(fr['motion_types'])
        lines.append(
            'Motion types: '
            + (', '.join(f'{k} {v} blocks' for k, v in sorted(mt.items())) or 'none')
            + f'; mean stick fraction {fmt(fr["stick_fraction_mean"], 2)}'
        )
    else:
        lines.append('Friction: no block estimates in the bag')
        lines.append('Motion types: unavailable')
    if results.get('wear'):
        we = as_mapping(results['wear'])
        v = as_opt_float(we['wear_volume_m3'])
        rate = as_opt_float(we['progressive_rate_m3_per_s'])
        kw = as_opt_float(we['k_w_progressive_m3_per_N_m'])
        lines.append(
            f'Wear after {fmt(as_float(we["test_time_s"]) / 60.0, 4)} min test time: '
            f'V_W = {fmt(None if v is None else v / UM3, 4)} um^3, progressive rate '
            f'{fmt(None if rate is None else rate * 60.0 / UM3, 4)} um^3/min, k_w = '
            f'{fmt(None if kw is None else kw / UM3, 3)} um^3/(N m)'
        )
    else:
        lines.append('Wear: no wear states in the bag')
    disc_raw = as_mapping(results.get('analyses', {})).get('discrepancy')
    disc = None if disc_raw is None else as_mapping(disc_raw)
    if disc is None:
        lines.append('Discrepancy workflow: not run')
    elif disc.get('finding'):
        lines.append(
            f'Discrepancy workflow: {disc["finding"]}'
            + (f' ({disc["note"]})' if disc.get('note') else '')
        )
    else:
        lines.append(f'Discrepancy workflow: unavailable ({disc.get("reason", "no result")})')
    sess = as_mapping(results.get('session') or {})
    streams = as_list(sess.get('streams') or [])
    if streams:
        samples = sum(as_int(as_mapping(st)['samples']) for st in streams)
        lines.append(
            f'Recording: {fmt(sess.get("duration_s"), 3)} s, {len(streams)} sample streams, '
            f'{samples} samples, missing samples = {sess.get("missing_samples", "n/a")}'
        )
    else:
        lines.append(
            f'Recording: {fmt(sess.get("duration_s"), 3)} s, no rig sample streams in the bag'
        )
    return lines
