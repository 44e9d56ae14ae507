"""Session report: one self-contained HTML page plus CSV/JSON results for a recorded bag.

:func:`build_report` reads a bag of the tribo graph and writes into ``out``:

- ``report.html``: one page, plots embedded as base64 PNG, inline CSS, no
  script and no network access needed to view it;
- ``results.json``: every number shown on the page (SI units; keys name the unit
  where it is not SI) plus the provenance (command line, versions, git commit);
- ``friction_blocks.csv``: the live per-block friction estimates recorded on
  ``/friction/estimate`` (paper section 2.5, Equ. 8);
- ``wear_states.csv``: the live nVCT wear states recorded on ``/nvct/wear``
  (paper section 3, Equ. 8-10);
- ``streams.csv``: sample continuity of every SampleBlock topic;
- ``analyses/<name>/``: the outputs of the offline analyses (``tribo friction``,
  ``tribo wear``, ``tribo discrepancy``) run on the bag through their
  commands' ``run(args)``; their PNG figures and JSON summaries are embedded.

A section whose input is missing (topic not in the bag, an analysis command
not installed or failing) is shown as unavailable with the reason; the report
itself never fails because of one section. Figures follow the paper:
Fig. 4/5 (mu0, mu_inf per block with the torsion-moment envelope), Fig. 6
(torsion-moment detail with stick phases), Fig. 10/11 (wear volume over test
time, running-in and progressive wear). They are written as
``friction_blocks.png``, ``motion_detail.png`` and ``wear_states.png`` and
embedded; Fig. 4/5 and 6 are drawn by :mod:`tribo_estimation.plots`, the stick
phases come from :func:`tribo_estimation.core.sticks.detect_sticks` (the
friction analysis' detection) on the full-rate rig streams.
"""

from __future__ import annotations

import base64
import csv
import html
import json
import math
import platform
import shlex
import sys
import time
import traceback
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
import yaml

from tribo_bringup import bagio
from tribo_bringup import bridge_core as bc
from tribo_bringup.errors import BagError, ConfigError
from tribo_estimation.core.config import load_rig_config
from tribo_estimation.errors import EstimationError

if TYPE_CHECKING:
    from tribo_estimation.core.model import RigParams
    from tribo_estimation.plots import DetailTrace

NS = 1_000_000_000
DETAIL_S = 0.25  # length of the Fig. 6 detail windows [s]
UM3 = 1e-18  # m^3 per um^3 (display unit of wear volumes)
FloatArray = npt.NDArray[np.float64]
Progress = Callable[[str], None]

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

#: Offline analyses: name -> (CLI command, section title).
ANALYSES: dict[str, tuple[str, str]] = {
    'friction': ('friction', 'Offline block-wise friction fit (tribo friction)'),
    'wear': ('wear', 'Offline nVCT wear evaluation (tribo wear)'),
    'discrepancy': ('discrepancy', 'Discrepancy workflow: missing physics (tribo discrepancy)'),
}

_PKGS = ('tribo_common', 'tribo_msgs', 'tribo_drivers', 'tribo_estimation', 'tribo_nvct')


# --- reading the bag -----------------------------------------------------------


@dataclass
class BagScan:
    """What the report needs from a bag (all times in ns, values SI).

    Attributes:
        counts: messages per topic.
        t_first_ns, t_last_ns: receive time of the first and last message [ns].
        estimates: one dict per /friction/estimate message (bridge_core field names).
        wear: one dict per /nvct/wear message.
        streams: sample continuity per SampleBlock topic.
    """

    counts: dict[str, int] = field(default_factory=dict)
    t_first_ns: int = 0
    t_last_ns: int = 0
    estimates: list[dict[str, Any]] = field(default_factory=list)
    wear: list[dict[str, Any]] = field(default_factory=list)
    streams: list[bagio.StreamCheck] = field(default_factory=list)
    truncated: str = ''


def scan_bag(path: str | Path) -> BagScan:
    """Read counts, estimates, wear states and stream continuity from a bag."""
    import warnings

    scan = BagScan()
    small = {'/friction/estimate', '/nvct/wear'}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter('always')
        for m in bagio.iter_messages(path, on_error='warn', deserialize=False):
            scan.counts[m.topic] = scan.counts.get(m.topic, 0) + 1
            if scan.t_first_ns == 0:
                scan.t_first_ns = m.timestamp_ns
            scan.t_last_ns = max(scan.t_last_ns, m.timestamp_ns)
        for m in bagio.iter_messages(path, small, on_error='warn'):
            if m.topic == '/friction/estimate':
                scan.estimates.append(bc.record_message(m.msg, bc.FRICTION_FIELDS, {}))
            else:
                scan.wear.append(bc.record_message(m.msg, bc.WEAR_FIELDS, {}))
        sample_topics = [t for t in bc.SAMPLE_TOPICS if scan.counts.get(t)]
        if sample_topics:
            scan.streams = bagio.check_streams(path, sample_topics)
    trunc = [str(w.message) for w in caught if 'truncated' in str(w.message)]
    scan.truncated = trunc[0] if trunc else ''
    if not scan.counts:
        raise BagError(f'{path}: the bag holds no message of a known type')
    return scan


@dataclass(frozen=True)
class RigWindow:
    """Aligned full-rate rig samples of a window (NaN where a channel lost samples).

    Attributes:
        sample_rate: sample rate [Hz].
        torsion: torsion moment C1*phi1 [N m].
        accel: chamber angular acceleration w1' [rad/s^2].
        speed: shaft speed w2 [rad/s].
    """

    sample_rate: float
    torsion: FloatArray
    accel: FloatArray
    speed: FloatArray


def read_rig_window(path: str | Path, first_index: int, seconds: float) -> RigWindow | None:
    """``seconds`` [s] of the /rig/* streams from sample ``first_index``, aligned by
    sample index as ``tribo friction`` aligns them; None when the bag has none there.

    Raises:
        BagError: no rig stream in the bag, or the bag is truncated before the window.
    """
    from tribo_bringup.commands.friction import bag_events
    from tribo_estimation.core.align import AlignedChunk, RestartEvent

    chunks: list[AlignedChunk] = []
    end: int | None = None
    for ev in bag_events(Path(path)):  # the generator (and the bag) closes on return
        if isinstance(ev, RestartEvent) and chunks:
            break  # a new stream epoch reuses the indices
        if not isinstance(ev, AlignedChunk):
            continue
        if end is None:
            end = first_index + max(1, round(seconds * ev.sample_rate))
        if ev.first_index >= end:
            break
        if ev.end_index > first_index:
            chunks.append(ev)
    if not chunks or end is None:
        return None
    rows = np.full((3, end - first_index), np.nan)
    for c in chunks:
        a, b = max(c.first_index, first_index), min(c.end_index, end)
        for row, data in zip(rows, (c.torsion, c.accel, c.speed), strict=True):
            row[a - first_index : b - first_index] = data[a - c.first_index : b - c.first_index]
    return RigWindow(chunks[0].sample_rate, rows[0], rows[1], rows[2])


def stick_flags(win: RigWindow, rig: RigParams) -> npt.NDArray[np.bool_]:
    """Per-sample stick flags of a window from the friction analysis' own stick detection
    (:func:`tribo_estimation.core.sticks.detect_sticks`: slip speed w2 - w1 and the stick
    residual of Equ. 1 + 2, phases >= 2 ms), run on each gap-free stretch."""
    from tribo_estimation.core.sticks import detect_sticks

    fs = win.sample_rate
    stick = np.zeros(win.torsion.size, dtype=bool)
    ok = np.isfinite(win.torsion) & np.isfinite(win.accel) & np.isfinite(win.speed)
    edges = np.flatnonzero(np.diff(np.concatenate(([0], ok.astype(np.int8), [0]))))
    for a, b in zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True):
        t = np.arange(a, b) / fs
        try:
            phases = detect_sticks(t, win.torsion[a:b], win.accel[a:b], win.speed[a:b], rig)
        except EstimationError:  # stretch too short for the detection
            continue
        for ph in phases:  # sample i sticks for start <= t_i < end, as in the block fit
            i0 = max(a, math.ceil(ph.start * fs - 1e-9))
            i1 = min(b, math.ceil(ph.end * fs - 1e-9))
            stick[i0:i1] = True
    return stick


# --- small helpers -----------------------------------------------------------------


def fmt(x: Any, digits: int = 4) -> str:
    """Number as text with ``digits`` significant digits ('n/a' for None/NaN)."""
    if x is None:
        return 'n/a'
    if isinstance(x, bool):
        return 'yes' if x else 'no'
    if isinstance(x, int):
        return str(x)
    if isinstance(x, float):
        if not math.isfinite(x):
            return 'n/a'
        return f'{x:.{digits}g}'
    return str(x)


def _finite(values: Iterable[Any]) -> FloatArray:
    arr = np.array([np.nan if v is None else float(v) for v in values], dtype=np.float64)
    return arr[np.isfinite(arr)]


def clean_json(obj: Any) -> Any:
    """Strict-JSON copy: NaN/inf -> None, numpy scalars -> Python, tuples -> lists."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, Mapping):
        return {str(k): clean_json(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [clean_json(v) for v in obj]
    if isinstance(obj, np.generic):
        return clean_json(obj.item())
    return obj


def _figure(draw: Callable[[Path], object], path: Path, caption: str) -> str:
    """Draw a figure into ``path`` (PNG) and embed it; a failing figure becomes a note."""
    try:
        draw(path)
        b64 = base64.b64encode(path.read_bytes()).decode('ascii')
    except Exception as exc:  # a figure never takes the report down
        why = html.escape(f'{type(exc).__name__}: {exc}')
        return f'<p class="na">Figure {html.escape(path.name)} unavailable: {why}</p>'
    return _img(b64, caption)


def _img(b64: str, caption: str) -> str:
    return (
        f'<figure><img alt="{html.escape(caption)}" src="data:image/png;base64,{b64}">'
        f'<figcaption>{html.escape(caption)}</figcaption></figure>'
    )


def _table(
    rows: Sequence[Sequence[Any]], header: Sequence[str], table_id: str = '', digits: int = 4
) -> str:
    tid = f' id="{table_id}"' if table_id else ''
    head = ''.join(f'<th>{html.escape(h)}</th>' for h in header)
    body = ''.join(
        '<tr>' + ''.join(f'<td>{html.escape(fmt(v, digits))}</td>' for v in row) + '</tr>'
        for row in rows
    )
    return f'<table{tid}><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>'


def _kv(items: Mapping[str, Any], table_id: str, units: Mapping[str, str] | None = None) -> str:
    rows = []
    for k, v in items.items():
        unit = (units or {}).get(k, '')
        rows.append(
            f'<tr><th>{html.escape(k)}</th><td data-key="{html.escape(k)}">'
            f'{html.escape(fmt(v))}</td><td>{html.escape(unit)}</td></tr>'
        )
    return f'<table id="{table_id}" class="kv"><tbody>{"".join(rows)}</tbody></table>'


def _write_csv(path: Path, rows: Sequence[Mapping[str, Any]], columns: Sequence[str]) -> None:
    with path.open('w', newline='', encoding='utf-8') as fh:
        w = csv.writer(fh)
        w.writerow(columns)
        for r in rows:
            w.writerow(
                [
                    ''
                    if r.get(c) is None
                    else repr(r[c])
                    if isinstance(r.get(c), float)
                    else r.get(c)
                    for c in columns
                ]
            )


# --- sections ----------------------------------------------------------------------


@dataclass
class Section:
    """One part of the page."""

    key: str
    title: str
    body: str
    available: bool = True


def _unavailable(key: str, title: str, reason: str) -> Section:
    return Section(key, title, f'<p class="na">Unavailable: {html.escape(reason)}</p>', False)


def load_rig(path: str | Path | None) -> dict[str, Any]:
    """RIG.yaml as a mapping (empty when ``path`` is None)."""
    if path is None:
        return {}
    p = Path(path)
    try:
        data = yaml.safe_load(p.read_text(encoding='utf-8'))
    except (OSError, yaml.YAMLError) as exc:
        raise ConfigError(f'{p}: cannot read rig file: {exc}') from exc
    if not isinstance(data, dict):
        raise ConfigError(f'{p}: a rig file is a mapping of parameter names to values')
    return data


def _load_nvct(path: str | Path | None) -> Any:
    """The run's NvctConfig (tribo_nvct's loader), or None when not given."""
    if path is None:
        return None
    from tribo_nvct.core.config import load_config

    return load_config(path)


def rig_section(rig: Mapping[str, Any], rig_path: str | None, results: dict) -> Section:
    title = 'Rig parameters used'
    if not rig:
        results['rig'] = None
        return _unavailable('rig', title, 'no RIG.yaml given (--rig)')
    params = {k: rig[k] for k in RIG_UNITS if k in rig}
    effects = rig.get('effects') or {}
    results['rig'] = {'file': rig_path, 'params': params, 'effects': dict(effects)}
    rows = [(k, float(v), RIG_UNITS[k][0], RIG_UNITS[k][1]) for k, v in params.items()]
    body = f'<p>From <code>{html.escape(str(rig_path))}</code>.</p>'
    body += _table(rows, ('parameter', 'value', 'unit', 'meaning'), 'rig-params', digits=6)
    if effects:
        body += '<p>Hidden model extensions switched on in the simulated rig: '
        body += ', '.join(
            f'<code>{html.escape(k)} = {fmt(float(v))}</code>' for k, v in effects.items()
        )
        body += '</p>'
    return Section('rig', title, body)


def session_section(bag: Path, scan: BagScan, results: dict, out: Path) -> Section:
    duration = (scan.t_last_ns - scan.t_first_ns) / NS
    missing = sum(s.missing for s in scan.streams)
    results['session'] = {
        'bag': str(bag),
        'duration_s': duration,
        'messages': dict(sorted(scan.counts.items())),
        'missing_samples': missing,
        'truncated': scan.truncated or None,
        'streams': [
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
        ],
    }
    _write_csv(
        out / 'streams.csv',
        results['session']['streams'],
        ('topic', 'first_index', 'messages', 'samples', 'missing', 'gaps', 'duplicates'),
    )
    body = _kv(
        {'recorded duration': duration, 'missing samples (all streams)': missing},
        'session-summary',
        {'recorded duration': 's', 'missing samples (all streams)': 'samples'},
    )
    rows = [
        (s.topic, s.first_index, s.messages, s.samples, s.missing, s.gaps, s.duplicates)
        for s in scan.streams
    ]
    body += _table(
        rows,
        ('stream', 'first index', 'blocks', 'samples', 'missing', 'gaps', 'duplicates'),
        'streams',
    )
    rows2 = sorted(scan.counts.items())
    body += _table(rows2, ('topic', 'messages'), 'topics')
    if scan.truncated:
        body += f'<p class="warn">{html.escape(scan.truncated)}</p>'
    return Section('session', f'Session: {bag.name}', body)


FRICTION_COLUMNS = (
    't_start', 't_end', 'first_index', 'mu0', 'mu0_se', 'mu_inf', 'mu_inf_se', 'k',
    'moment_min', 'moment_max', 'moment_mean', 'motion', 'n_sticks', 'stick_fraction',
    'rms_residual', 'quality',
)  # fmt: skip


def offline_blocks(directory: Path) -> list[dict[str, Any]]:
    """Blocks of a ``tribo friction`` run (its ``blocks.csv``) as estimate dicts; [] if none.

    Read with :func:`tribo_estimation.core.blockfit.read_blocks_csv`; NaN becomes None and
    fields that blocks.csv lacks (``first_index``, ``k``, ``k_se``) are None.
    """
    from tribo_estimation.core.blockfit import read_blocks_csv

    found = sorted(directory.rglob('blocks.csv')) if directory.is_dir() else []
    if not found:
        return []
    try:
        table = read_blocks_csv(found[0])
    except EstimationError:
        return []
    out: list[dict[str, Any]] = []
    for i in range(len(table['t_start'])):
        e: dict[str, Any] = {}
        for name, (kind, _desc) in bc.FRICTION_FIELDS.items():
            if name not in table:
                e[name] = None
            elif kind == 'string':
                e[name] = str(table[name][i])
            else:
                v = float(table[name][i])
                e[name] = None if not math.isfinite(v) else int(v) if kind == 'integer' else v
        if e['t_start'] is not None:
            out.append(e)
    return out


def block_table(ests: Sequence[Mapping[str, Any]]) -> dict[str, np.ndarray]:
    """Estimates as a block table: ``blocks.csv`` column -> array (None -> NaN), the input
    of :mod:`tribo_estimation.plots`."""
    from tribo_estimation.core.blockfit import CSV_COLUMNS

    table: dict[str, np.ndarray] = {}
    for c in CSV_COLUMNS:
        if bc.FRICTION_FIELDS[c][0] == 'string':
            table[c] = np.array([str(e[c]) for e in ests], dtype=object)
        else:
            table[c] = np.array([np.nan if e[c] is None else e[c] for e in ests], dtype=float)
    return table


def detail_trace(
    bag: Path, est: Mapping[str, Any], t_ref: float, rig: RigParams | None, seconds: float
) -> DetailTrace | None:
    """Fig. 6 trace: ``seconds`` [s] of torsion moment from the start of block ``est``
    with the stick phases of the core detection (:func:`stick_flags`, run over the whole
    block as the friction fit does; none without rig parameters). Time axis [s] from
    ``t_ref``, the first block's start. None when the bag has no rig samples there."""
    from tribo_estimation.plots import DetailTrace

    span = float(est['t_end'] - est['t_start']) if est.get('t_end') is not None else seconds
    win = read_rig_window(bag, int(est['first_index']), min(max(span, seconds), 5.0))
    if win is None:
        return None
    stick = stick_flags(win, rig) if rig is not None else np.zeros(win.torsion.size, bool)
    n = min(win.torsion.size, max(1, round(seconds * win.sample_rate)))
    t0 = float(est['t_start']) - t_ref
    nan = np.full(n, np.nan)
    title = f'{est["motion"]} block at t = {t0:.0f} s'
    return DetailTrace(
        title, t0 + np.arange(n) / win.sample_rate, win.torsion[:n], nan, nan, stick[:n]
    )


def friction_section(
    ests: list[dict[str, Any]],
    source: str,
    results: dict,
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
            _unavailable(
                'friction',
                'Friction per block',
                'no /friction/estimate messages in the bag and no offline fit result',
            )
        ]
    _write_csv(out / 'friction_blocks.csv', ests, FRICTION_COLUMNS)
    good = [e for e in ests if e['quality'] == 'ok']
    mu0 = _finite(e['mu0'] for e in good)
    muinf = _finite(e['mu_inf'] for e in good)
    motions: dict[str, int] = {}
    for e in good:
        motions[e['motion']] = motions.get(e['motion'], 0) + 1
    summary: dict[str, Any] = {
        'blocks': len(ests),
        'blocks_ok': len(good),
        'mu0_min': float(mu0.min()) if mu0.size else None,
        'mu0_max': float(mu0.max()) if mu0.size else None,
        'mu0_mean': float(mu0.mean()) if mu0.size else None,
        'mu_inf_min': float(muinf.min()) if muinf.size else None,
        'mu_inf_max': float(muinf.max()) if muinf.size else None,
        'mu_inf_mean': float(muinf.mean()) if muinf.size else None,
        'motion_types': motions,
        'stick_fraction_mean': float(np.mean(_finite(e['stick_fraction'] for e in good)))
        if good
        else None,
    }
    summary['source'] = source
    results['friction'] = summary
    body = _kv(
        {k: v for k, v in summary.items() if k not in ('motion_types', 'source')},
        'friction-summary',
    )
    body += (
        '<p>Motion types of the good blocks: '
        + (', '.join(f'{html.escape(k)}: <b>{v}</b>' for k, v in sorted(motions.items())) or 'none')
        + '</p>'
    )
    from tribo_estimation.plots import plot_blocks, plot_detail

    body += _figure(
        lambda p: plot_blocks(block_table(ests), p, title=f'friction per block ({source})'),
        out / 'friction_blocks.png',
        'Fig. 4/5 style: torsion moment max/mean/min per block (top), mu0 and mu_inf per '
        'block with +-1 SE (bottom); flagged blocks grey crosses',
    )
    rows = [
        (
            e['t_start'] - ests[0]['t_start'],
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
    body += _table(
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
    picks: list[dict[str, Any]] = []
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
            d = detail_trace(bag, e, float(ests[0]['t_start']), rig, DETAIL_S)
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
        img = _figure(
            lambda p: plot_detail(details, p),
            out / 'motion_detail.png',
            f'Torsion moment C1*phi1 over {DETAIL_S:g} s from the block start; {how}',
        )
        sections.append(Section('detail', 'Motion detail (Fig. 6 style)', img))
    elif reasons:
        sections.append(_unavailable('detail', 'Motion detail (Fig. 6 style)', '; '.join(reasons)))
    return sections


def wear_section(scan: BagScan, nvct: Any, results: dict, out: Path) -> Section:
    """Live wear states; ``nvct`` is the run's NvctConfig (k_w, window) or None."""
    title = 'nVCT wear (live wear monitor, /nvct/wear)'
    ws = scan.wear
    if not ws:
        results['wear'] = None
        return _unavailable('wear', title, 'no /nvct/wear messages in the bag')
    cols = ('t', *[k for k in bc.WEAR_FIELDS if k != 't'])
    _write_csv(out / 'wear_states.csv', ws, cols)
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
    body = _kv(summary, 'wear-summary', units)
    w0, w1 = (w / 60.0 for w in (nvct.window_s if nvct is not None else (7200.0, 10800.0)))
    body += _figure(
        lambda p: _plot_wear(ws, p, (w0, w1)),
        out / 'wear_states.png',
        'Fig. 10/11 style: wear volume over test time (+-2 SE band), '
        f'progressive wear line (slope {w0:g}-{w1:g} min) and running-in volume',
    )
    return Section('wear', title, body)


def analysis_section(key: str, title: str, status: Mapping[str, Any], out: Path) -> Section:
    """Embed an analysis command's outputs (PNG figures, JSON summaries, CSV list)."""
    if not status.get('ok'):
        return _unavailable(key, title, str(status.get('reason', 'not run')))
    d = out / str(status['dir'])
    body = f'<p>Command: <code>{html.escape(str(status["command"]))}</code> '
    body += f'({status["seconds"]:.1f} s). Outputs in <code>{html.escape(str(status["dir"]))}'
    body += '</code>.</p>'
    if status.get('note'):
        body += f'<p class="note">{html.escape(str(status["note"]))}</p>'
    for js in sorted(d.rglob('*.json')):
        try:
            data = json.loads(js.read_text(encoding='utf-8'))
        except (OSError, ValueError):
            continue
        body += f'<details><summary>{html.escape(str(js.relative_to(out)))}</summary>'
        body += _json_html(data) + '</details>'
        if key == 'discrepancy' and js.name.startswith('discrepancy') and isinstance(data, dict):
            body = _discrepancy_findings(data) + body
    for png in sorted(d.rglob('*.png')):
        body += _img(base64.b64encode(png.read_bytes()).decode('ascii'), str(png.relative_to(out)))
    csvs = sorted(d.rglob('*.csv'))
    if csvs:
        body += (
            '<p>CSV results: '
            + ', '.join(f'<code>{html.escape(str(c.relative_to(out)))}</code>' for c in csvs)
            + '</p>'
        )
    return Section(key, title, body)


def _json_html(data: Any, depth: int = 0) -> str:
    if isinstance(data, Mapping) and depth < 3:
        rows = ''.join(
            f'<tr><th>{html.escape(str(k))}</th><td>{_json_html(v, depth + 1)}</td></tr>'
            for k, v in data.items()
        )
        return f'<table class="kv"><tbody>{rows}</tbody></table>'
    if isinstance(data, list) and data and depth < 3 and len(data) <= 20:
        return '<br>'.join(_json_html(v, depth + 1) for v in data)
    text = json.dumps(data) if not isinstance(data, (int, float, str)) else fmt(data)
    if len(text) > 300:
        text = text[:300] + ' ...'
    return html.escape(text)


def _discrepancy_findings(data: Mapping[str, Any]) -> str:
    return (
        f'<p class="finding" id="discrepancy-finding">Finding: '
        f'{html.escape(discrepancy_finding(data))}.</p>'
    )


def discrepancy_finding(data: Mapping[str, Any]) -> str:
    """One-line text of a discrepancy.json result (effects found, their values, residual RMS)."""
    added = data.get('added') or []
    base = (data.get('baseline') or {}).get('rms')
    final = (data.get('final') or {}).get('rms')
    rms = f'torque residual RMS {fmt(base, 3)} -> {fmt(final, 3)} N m'
    if not added:
        return f'no missing effect found ({rms})'
    parts = []
    for a in added:
        units = a.get('units') or {}
        params = ', '.join(
            f'{k} = {fmt(v, 3)} {units.get(k, "").strip("-")}'.rstrip()
            for k, v in (a.get('params') or {}).items()
        )
        parts.append(f'{a.get("effect")} ({params})')
    return f'found {"; ".join(parts)}; {rms}'


# --- plots ---------------------------------------------------------------------------


def _plt() -> Any:
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    return plt


def _plot_wear(
    ws: Sequence[Mapping[str, Any]], path: Path, window_min: tuple[float, float]
) -> None:
    """Fig. 10/11 style wear volume over test time from the live wear states; the
    progressive-rate window [min] shaded."""
    plt = _plt()

    def col(name: str) -> FloatArray:
        return np.array([np.nan if w[name] is None else w[name] for w in ws], dtype=float)

    t_min = col('t') / 60.0
    v, se = col('wear_volume') / UM3, col('wear_volume_se') / UM3
    fig, ax = plt.subplots(figsize=(9, 4.2))
    ax.fill_between(t_min, v - 2 * se, v + 2 * se, color='tab:brown', alpha=0.25, label='+-2 SE')
    ax.plot(t_min, v, '.', ms=3, color='tab:brown', label='wear volume V_W')
    last = ws[-1]
    rate, vr = last['progressive_rate'], last['running_in_volume']
    if rate is not None and vr is not None:
        tt = np.linspace(0.0, float(np.nanmax(t_min)), 50)
        ax.plot(
            tt,
            (vr + rate * tt * 60.0) / UM3,
            '-',
            color='k',
            lw=1,
            label='running-in + progressive line',
        )
        ax.axhline(vr / UM3, color='tab:green', ls=':', label=f'running-in {vr / UM3:.4g} um^3')
        w0, w1 = window_min
        ax.axvspan(w0, w1, color='0.85', alpha=0.5, label=f'{w0:g}-{w1:g} min window')
    ax.set_xlabel('test time [min]')
    ax.set_ylabel('wear volume [um^3]')
    ax.legend(fontsize=8, loc='upper left')
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=110, bbox_inches='tight')
    plt.close(fig)


# --- analyses ---------------------------------------------------------------------


def run_command(argv: Sequence[str]) -> None:
    """Run ``tribo <argv>`` in this process; raises on failure."""
    from tribo_bringup.cli import build_parser

    args = build_parser().parse_args(list(argv))
    code = int(args.func(args) or 0)
    if code != 0:
        raise BringupCommandError(f'tribo {argv[0]} exited with code {code}')


class BringupCommandError(RuntimeError):
    """An analysis command failed (the report shows its section as unavailable)."""


def run_analysis(
    key: str,
    argv: Sequence[str],
    out: Path,
    progress: Progress,
    note: str = '',
) -> dict[str, Any]:
    """Run one analysis command writing into ``out/analyses/<key>``; never raises."""
    rel = Path('analyses') / key
    command = 'tribo ' + shlex.join(argv)
    status: dict[str, Any] = {'ok': False, 'dir': str(rel), 'command': command, 'note': note}
    t0 = time.monotonic()
    progress(f'{key}: {command}')
    try:
        run_command(argv)
        status['ok'] = True
    except SystemExit as exc:  # argparse usage error
        status['reason'] = f'tribo {argv[0]}: bad arguments (exit {exc.code})'
    except Exception as exc:  # any failure of one analysis leaves the rest of the report
        status['reason'] = (
            f'{type(exc).__name__}: {str(exc).strip().splitlines()[0] if str(exc).strip() else ""}'
        )
        status['traceback'] = traceback.format_exc(limit=4)
    finally:
        status['seconds'] = time.monotonic() - t0
    progress(
        f'{key}: {"done" if status["ok"] else "unavailable: " + status["reason"]} '
        f'({status["seconds"]:.1f} s)'
    )
    return status


def analysis_argv(
    key: str,
    bag: Path,
    out: Path,
    rig: str | None,
    nvct: str | None,
    extra: Sequence[str] = (),
) -> list[str]:
    """Command line of an analysis (``tribo friction|wear|discrepancy BAG ...``)."""
    cmd = ANALYSES[key][0]
    argv = [cmd, str(bag), '--out', str(out / 'analyses' / key)]
    if key == 'wear':
        if nvct:
            argv += ['--nvct', nvct]
    elif rig:
        argv += ['--rig', rig]
    return argv + list(extra)


# --- provenance --------------------------------------------------------------------


def _version(module: str) -> str:
    try:
        from importlib.metadata import version

        return version(module)
    except Exception:
        try:
            mod = __import__(module)
            return str(getattr(mod, '__version__', 'unknown'))
        except Exception:
            return 'not installed'


def _tribo_version(pkg: str, root: Path) -> str:
    xml = root / 'src' / pkg / 'package.xml'
    try:
        text = xml.read_text(encoding='utf-8')
        return text.split('<version>')[1].split('</version>')[0].strip()
    except (OSError, IndexError):
        return 'unknown'


def git_commit(root: Path) -> str | None:
    """Commit of the working tree read from ``.git`` (no git command), or None."""
    git = root / '.git'
    try:
        head = (git / 'HEAD').read_text(encoding='utf-8').strip()
        if not head.startswith('ref:'):
            return head
        ref = head.split(None, 1)[1]
        ref_file = git / ref
        if ref_file.is_file():
            return ref_file.read_text(encoding='utf-8').strip()
        packed = git / 'packed-refs'
        if packed.is_file():
            for line in packed.read_text(encoding='utf-8').splitlines():
                if line.endswith(' ' + ref):
                    return line.split()[0]
    except OSError:
        return None
    return None


def provenance(command: Sequence[str] | None) -> dict[str, Any]:
    """Command line, versions and git commit that produced a report."""
    root = Path(__file__).resolve().parents[3]
    versions = {
        'python': platform.python_version(),
        **{m: _version(m) for m in ('numpy', 'scipy', 'numba', 'rosbags', 'matplotlib')},
        'foxglove-sdk': _version('foxglove-sdk'),
    }
    versions.update({p: _tribo_version(p, root) for p in ('tribo_bringup', *_PKGS)})
    return {
        'command': shlex.join(command if command is not None else sys.argv),
        'versions': versions,
        'git_commit': git_commit(root),
        'platform': platform.platform(),
        'created': time.strftime('%Y-%m-%d %H:%M:%S %z'),
    }


# --- page ------------------------------------------------------------------------

CSS = """
body{font-family:system-ui,-apple-system,'Segoe UI',sans-serif;margin:2em auto;max-width:1100px;
color:#222;padding:0 1em}
h1{font-size:1.6em}h2{font-size:1.25em;border-bottom:1px solid #ccc;padding-bottom:.2em;
margin-top:1.8em}
table{border-collapse:collapse;margin:.6em 0;font-size:.88em}
th,td{border:1px solid #ddd;padding:.25em .6em;text-align:right}th{background:#f4f4f4}
table.kv th{text-align:left}td:first-child{text-align:left}
figure{margin:1em 0}img{max-width:100%}figcaption{font-size:.85em;color:#555}
.na{color:#a33;font-style:italic}.warn{color:#a60}.finding{font-weight:bold}
code{background:#f4f4f4;padding:0 .2em}nav a{margin-right:1em}
ul.summary li{margin:.2em 0}
"""


def render_html(
    title: str, summary: Sequence[str], sections: Sequence[Section], prov: Mapping
) -> str:
    nav = ''.join(f'<a href="#{s.key}">{html.escape(s.title.split(" (")[0])}</a>' for s in sections)
    parts = [
        '<!DOCTYPE html><html lang="en"><head><meta charset="utf-8">',
        f'<title>{html.escape(title)}</title>',
        '<meta name="viewport" content="width=device-width,initial-scale=1">',
        f'<style>{CSS}</style></head><body>',
        f'<h1>{html.escape(title)}</h1>',
        '<ul class="summary" id="summary">',
        *[f'<li>{html.escape(line)}</li>' for line in summary],
        '</ul>',
        f'<nav>{nav}<a href="#provenance">Provenance</a></nav>',
    ]
    for s in sections:
        parts.append(f'<section id="{s.key}"><h2>{html.escape(s.title)}</h2>{s.body}</section>')
    vers = _table(sorted(prov['versions'].items()), ('package', 'version'), 'versions')
    parts.append(
        '<section id="provenance"><h2>Provenance</h2>'
        f'<p>Command: <code id="command">{html.escape(prov["command"])}</code></p>'
        f'<p>Git commit: <code>{html.escape(str(prov["git_commit"] or "unknown"))}</code>; '
        f'created {html.escape(prov["created"])} on {html.escape(prov["platform"])}.</p>'
        f'{vers}</section>'
    )
    parts.append('</body></html>')
    return '\n'.join(parts)


def summary_lines(results: Mapping[str, Any]) -> list[str]:
    """Five lines telling the story of the session (used by the page and ``tribo demo``)."""
    lines: list[str] = []
    fr = results.get('friction')
    if fr:
        lines.append(
            f'Friction: {fr["blocks_ok"]} of {fr["blocks"]} blocks fitted; mu0 '
            f'{fmt(fr["mu0_min"], 3)}..{fmt(fr["mu0_max"], 3)}, mu_inf '
            f'{fmt(fr["mu_inf_min"], 3)}..{fmt(fr["mu_inf_max"], 3)}'
        )
        mt = fr['motion_types']
        lines.append(
            'Motion types: '
            + (', '.join(f'{k} {v} blocks' for k, v in sorted(mt.items())) or 'none')
            + f'; mean stick fraction {fmt(fr["stick_fraction_mean"], 2)}'
        )
    else:
        lines.append('Friction: no block estimates in the bag')
        lines.append('Motion types: unavailable')
    we = results.get('wear')
    if we:
        v = we['wear_volume_m3']
        rate = we['progressive_rate_m3_per_s']
        kw = we['k_w_progressive_m3_per_N_m']
        lines.append(
            f'Wear after {fmt(we["test_time_s"] / 60.0, 4)} min test time: '
            f'V_W = {fmt(None if v is None else v / UM3, 4)} um^3, progressive rate '
            f'{fmt(None if rate is None else rate * 60.0 / UM3, 4)} um^3/min, k_w = '
            f'{fmt(None if kw is None else kw / UM3, 3)} um^3/(N m)'
        )
    else:
        lines.append('Wear: no wear states in the bag')
    disc = results.get('analyses', {}).get('discrepancy')
    if disc is None:
        lines.append('Discrepancy workflow: not run')
    elif disc.get('finding'):
        lines.append(
            f'Discrepancy workflow: {disc["finding"]}'
            + (f' ({disc["note"]})' if disc.get('note') else '')
        )
    else:
        lines.append(f'Discrepancy workflow: unavailable ({disc.get("reason", "no result")})')
    sess = results.get('session') or {}
    streams = sess.get('streams') or []
    if streams:
        samples = sum(int(st['samples']) for st in streams)
        lines.append(
            f'Recording: {fmt(sess.get("duration_s"), 3)} s, {len(streams)} sample streams, '
            f'{samples} samples, missing samples = {sess.get("missing_samples", "n/a")}'
        )
    else:
        lines.append(
            f'Recording: {fmt(sess.get("duration_s"), 3)} s, no rig sample streams in the bag'
        )
    return lines


@dataclass(frozen=True)
class ReportResult:
    """Where the report went and what it says."""

    html: Path
    results: dict[str, Any]
    summary: list[str]


def build_report(
    bag: str | Path,
    out: str | Path,
    *,
    rig: str | Path | None = None,
    nvct: str | Path | None = None,
    discrepancy: bool = False,
    analysis_rig: str | Path | None = None,
    analyses: Sequence[str] = ('friction', 'wear'),
    extra_args: Mapping[str, Sequence[str]] | None = None,
    notes: Mapping[str, str] | None = None,
    command: Sequence[str] | None = None,
    progress: Progress | None = None,
) -> ReportResult:
    """Write the session report of ``bag`` into directory ``out``.

    Args:
        bag: recorded bag (directory or .mcap).
        out: output directory (created; existing report files are replaced).
        rig: RIG.yaml of the run (rig parameter table; rig parameters of the stick detection).
        nvct: NVCT.yaml (wear analysis, k_w).
        discrepancy: also run ``tribo discrepancy`` on the bag.
        analysis_rig: RIG.yaml given to the analyses (default ``rig``); e.g. the nominal
            rig without the hidden effects the simulated rig ran with.
        analyses: offline analyses to run besides the discrepancy workflow.
        extra_args: extra command-line arguments per analysis.
        notes: a note per analysis shown in its section (e.g. analysed window).
        command: the command line to record (default ``sys.argv``).
        progress: callback for progress lines (default: stderr).
    """
    say = progress or (lambda s: print(f'report: {s}', file=sys.stderr, flush=True))
    bag_p = Path(bag)
    out_p = Path(out)
    if not bag_p.exists():
        raise BagError(f'{bag_p}: no such bag')
    out_p.mkdir(parents=True, exist_ok=True)
    rig_s = str(rig) if rig is not None else None
    nvct_s = str(nvct) if nvct is not None else None
    rig_data = load_rig(rig)
    nvct_cfg = _load_nvct(nvct)
    results: dict[str, Any] = {'analyses': {}}
    say(f'reading {bag_p}')
    scan = scan_bag(bag_p)
    rig_params, rig_note = None, 'no RIG.yaml given (--rig)'
    if rig is not None:
        try:
            rig_params = load_rig_config(rig).rig
        except EstimationError as exc:
            rig_note = f'rig parameters unusable: {exc}'
    sections = [session_section(bag_p, scan, results, out_p), rig_section(rig_data, rig_s, results)]
    wear_sec = wear_section(scan, nvct_cfg, results, out_p)
    todo = [a for a in analyses if a in ANALYSES]
    if discrepancy:
        todo.append('discrepancy')
    analysis_sections: list[Section] = []
    for key in todo:
        if key == 'wear' and nvct_s is None:
            status: dict[str, Any] = {'ok': False, 'reason': 'no NVCT.yaml given (--nvct)'}
        elif key == 'wear' and not scan.counts.get('/nvct/counts'):
            status = {'ok': False, 'reason': 'no /nvct/counts in the bag'}
        else:
            argv = analysis_argv(
                key,
                bag_p,
                out_p,
                str(analysis_rig) if analysis_rig is not None else rig_s,
                nvct_s,
                (extra_args or {}).get(key, ()),
            )
            status = run_analysis(key, argv, out_p, say, (notes or {}).get(key, ''))
        if key == 'discrepancy' and status.get('ok'):
            found = sorted((out_p / str(status['dir'])).rglob('discrepancy*.json'))
            if found:
                try:
                    status['finding'] = discrepancy_finding(json.loads(found[0].read_text()))
                except (OSError, ValueError) as exc:
                    status['reason'] = f'cannot read {found[0].name}: {exc}'
        results['analyses'][key] = {k: v for k, v in status.items() if k != 'traceback'}
        analysis_sections.append(analysis_section(key, ANALYSES[key][1], status, out_p))
    if scan.estimates:
        ests, source = scan.estimates, 'live estimator, /friction/estimate'
    else:
        ests = offline_blocks(out_p / 'analyses' / 'friction')
        source = 'offline fit, tribo friction'
    say('friction section and plots')
    sections += friction_section(ests, source, results, out_p, bag_p, rig_params, rig_note)
    sections.append(wear_sec)
    sections += analysis_sections
    prov = provenance(command)
    results['provenance'] = prov
    summary = summary_lines(results)
    results['summary'] = summary
    (out_p / 'results.json').write_text(
        json.dumps(clean_json(results), indent=2, allow_nan=False) + '\n', encoding='utf-8'
    )
    page = render_html(f'tribo session report: {bag_p.name}', summary, sections, prov)
    html_path = out_p / 'report.html'
    html_path.write_text(page, encoding='utf-8')
    say(f'wrote {html_path}')
    return ReportResult(html_path, results, summary)
