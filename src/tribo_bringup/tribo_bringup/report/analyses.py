"""The offline analyses of the session report, run through the library functions.

Each analysis reads the bag through :mod:`tribo_bringup.sessions`, calls the
same library functions as its command (``tribo friction``: the streaming block
fit :func:`tribo_estimation.core.blockfit.estimate_blocks`; ``tribo wear``:
:class:`tribo_nvct.core.streaming.WearEvaluator`; ``tribo discrepancy``:
:func:`tribo_estimation.core.discrepancy.run_discrepancy`), writes its results
and figures into ``analyses/<name>/`` of the report and returns an
:class:`AnalysisOutcome` with the numbers in memory. An analysis that fails
never takes the report down: its outcome names the reason.
"""

from __future__ import annotations

import math
import time
import traceback
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from tribo_bringup.errors import BagError
from tribo_bringup.sessions import bag_dwells, read_rig_stretch, rig_bag_events

from .page import as_list, as_mapping, fmt

if TYPE_CHECKING:
    from tribo_estimation.core.blockfit import BlockResult

Progress = Callable[[str], None]

#: Offline analyses: name -> section title.
ANALYSES: dict[str, str] = {
    'friction': 'Offline block-wise friction fit (tribo friction)',
    'wear': 'Offline nVCT wear evaluation (tribo wear)',
    'discrepancy': 'Discrepancy workflow: missing physics (tribo discrepancy)',
}

#: Fewest samples the discrepancy workflow is given.
MIN_DISCREPANCY_SAMPLES = 100


@dataclass
class AnalysisOutcome:
    """What one offline analysis produced.

    Attributes
    ----------
    key
        analysis name (``friction``, ``wear``, ``discrepancy``).
    ok
        it ran to the end.
    directory
        its output directory relative to the report directory.
    what
        the library call it made (one line).
    seconds
        wall time [s].
    note
        a note shown with the section (e.g. the analysed window).
    reason
        why it failed ('' when ok).
    summary
        its numbers (SI; keys name the unit where not SI).
    figures
        PNG files it wrote (absolute paths).
    files
        other result files it wrote (absolute paths).
    finding
        one-line finding (discrepancy workflow).
    blocks
        per-block estimates as /friction/estimate dicts (friction fit).
    traceback
        the failure's traceback (not in results.json).
    """

    key: str
    ok: bool = False
    directory: str = ''
    what: str = ''
    seconds: float = 0.0
    note: str = ''
    reason: str = ''
    summary: dict[str, Any] = field(default_factory=dict)
    figures: list[Path] = field(default_factory=list)
    files: list[Path] = field(default_factory=list)
    finding: str = ''
    blocks: list[dict[str, Any]] = field(default_factory=list)
    traceback: str = ''

    def status(self) -> dict[str, object]:
        """Plain mapping for results.json (paths relative to the report, no traceback)."""
        out: dict[str, Any] = {
            'ok': self.ok,
            'dir': self.directory,
            'call': self.what,
            'seconds': self.seconds,
            'note': self.note,
        }
        if not self.ok:
            out['reason'] = self.reason
        if self.finding:
            out['finding'] = self.finding
        return out


def run_analysis(
    key: str,
    work: Callable[[AnalysisOutcome, Path], None],
    out: Path,
    progress: Progress,
    note: str = '',
) -> AnalysisOutcome:
    """Run ``work(outcome, directory)`` for analysis ``key``, writing into ``out/analyses/<key>``.

    Never raises: a failure is recorded in the outcome.
    """
    rel = Path('analyses') / key
    res = AnalysisOutcome(key, directory=str(rel), note=note)
    t0 = time.monotonic()
    progress(f'{key}: running')
    try:
        d = out / rel
        d.mkdir(parents=True, exist_ok=True)
        work(res, d)
        res.ok = True
    except Exception as exc:  # any failure of one analysis leaves the rest of the report
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else ''
        res.reason = f'{type(exc).__name__}: {first}'
        res.traceback = traceback.format_exc(limit=4)
    finally:
        res.seconds = time.monotonic() - t0
    progress(f'{key}: {"done" if res.ok else "unavailable: " + res.reason} ({res.seconds:.1f} s)')
    return res


def failed(key: str, reason: str) -> AnalysisOutcome:
    """Record an analysis that could not start (input missing)."""
    return AnalysisOutcome(key, reason=reason)


# --- friction ----------------------------------------------------------------------


def friction_work(bag: Path, rig_file: Path) -> Callable[[AnalysisOutcome, Path], None]:
    """Make the block-wise mu0/mu_inf fit of the bag's rig streams (paper 2.5, Equ. 8).

    The work writes ``blocks.csv`` and ``blocks.png`` (Fig. 4/5 layout).
    """

    def work(res: AnalysisOutcome, d: Path) -> None:
        from tribo_bringup import bridge_core as bc
        from tribo_estimation.core.blockfit import (
            BlockConfig,
            BlockCsvWriter,
            estimate_blocks,
            results_table,
        )
        from tribo_estimation.core.config import load_rig_config
        from tribo_estimation.plots import plot_blocks

        cfg_rig = load_rig_config(rig_file)
        nominal = cfg_rig.drive.nominal_speed
        cfg = BlockConfig(
            nominal_speed=nominal if nominal > 0.0 else None, ramp_time=cfg_rig.drive.ramp_time
        )
        res.what = f'estimate_blocks(rig of {rig_file.name}, block {cfg.block_length:g} s)'
        results = []
        with BlockCsvWriter(d / 'blocks.csv') as writer:
            for det in estimate_blocks(cfg_rig.rig, cfg_rig.friction, cfg, rig_bag_events(bag)):
                writer.write(det.result)
                results.append(det.result)
        if not results:
            raise BagError(f'{bag}: no complete block of rig data')
        res.files.append(d / 'blocks.csv')
        res.blocks = [block_estimate(r, bc.FRICTION_FIELDS) for r in results]
        n_ok = sum(r.ok for r in results)
        res.summary = {
            'blocks': len(results),
            'blocks_ok': n_ok,
            'block_length_s': cfg.block_length,
        }
        plot_blocks(results_table(results), d / 'blocks.png', title='offline friction per block')
        res.figures.append(d / 'blocks.png')

    return work


def block_estimate(r: BlockResult, fields: Mapping[str, tuple[str, str]]) -> dict[str, object]:
    """Convert a block result to a /friction/estimate dict.

    ``fields`` maps name -> (JSON type, description); NaN becomes None, the
    quality ``ok`` or its ``;``-joined flags.
    """
    out: dict[str, Any] = {}
    for name, (kind, _desc) in fields.items():
        if name == 'quality':
            out[name] = r.quality_str
            continue
        value = getattr(r, name)
        if kind == 'string':
            out[name] = str(value)
            continue
        v = float(value)
        out[name] = None if not math.isfinite(v) else int(v) if kind == 'integer' else v
    return out


# --- wear --------------------------------------------------------------------------


def wear_work(bag: Path, nvct_file: Path) -> Callable[[AnalysisOutcome, Path], None]:
    """Make the nVCT evaluation of the bag's /nvct/counts (paper 3, Equ. 8-10).

    The work writes ``summary.json`` and ``wear.png`` (Fig. 10/11).
    """

    def work(res: AnalysisOutcome, d: Path) -> None:
        import json

        from tribo_nvct.core.config import load_config
        from tribo_nvct.core.streaming import WearEvaluator
        from tribo_nvct.plots import plot_wear_run

        from .page import clean_json

        cfg = load_config(nvct_file)
        res.what = f'WearEvaluator(config {nvct_file.name})'
        dwells, truncated = bag_dwells(bag)
        ev = WearEvaluator(cfg)
        for dw in dwells:
            ev.add(dw)
        evaluation = ev.evaluation()
        dwell_s = float(sorted(dw.real_time for dw in dwells)[len(dwells) // 2])
        summary = dict(evaluation.summary(cfg, dwell_s))
        summary['dwells'] = len(ev.points)
        summary['input_truncated'] = str(truncated) if truncated else None
        res.summary = summary
        (d / 'summary.json').write_text(
            json.dumps(clean_json(summary), indent=2, allow_nan=False) + '\n', encoding='utf-8'
        )
        res.files.append(d / 'summary.json')
        plot_wear_run(d / 'wear.png', ev.points, evaluation, cfg)
        res.figures.append(d / 'wear.png')

    return work


# --- discrepancy -------------------------------------------------------------------


def discrepancy_work(
    bag: Path, rig_file: Path, window: tuple[float, float], progress: Progress
) -> Callable[[AnalysisOutcome, Path], None]:
    """Make the missing-physics workflow on a window of the bag's rig streams.

    ``window`` = (start, duration) [s] (duration 0: to the end); the work writes
    ``discrepancy.json`` and its plots.
    """

    def work(res: AnalysisOutcome, d: Path) -> None:
        import numpy as np

        from tribo_estimation.core.config import load_rig_config
        from tribo_estimation.core.discrepancy import run_discrepancy
        from tribo_estimation.core.discrepancy.fitting import Record
        from tribo_estimation.core.discrepancy.plots import write_plots
        from tribo_estimation.core.discrepancy.report import to_dict, write_json

        cfg = load_rig_config(rig_file)
        start, duration = window
        (t, torque, accel, speed), truncated = read_rig_stretch(bag, start, duration, progress)
        if t.size < MIN_DISCREPANCY_SAMPLES:
            raise BagError(
                f'{bag}: the window start {start:g} s, duration {duration:g} s holds '
                f'{t.size} samples (need >= {MIN_DISCREPANCY_SAMPLES})'
            )
        arrays = (np.ascontiguousarray(a, dtype=np.float64) for a in (t, torque, accel, speed))
        record = Record(*arrays)
        res.what = (
            f'run_discrepancy({record.time.size} samples, '
            f'{record.time[-1] - record.time[0]:.2f} s; rig of {rig_file.name})'
        )
        result = run_discrepancy(
            record, cfg.rig, cfg.drive, k=cfg.friction.k, progress=lambda s: progress(f'  {s}')
        )
        res.files.append(write_json(result, d / 'discrepancy.json'))
        res.figures.extend(write_plots(result, d))
        data = to_dict(result)
        res.summary = {k: data[k] for k in ('baseline', 'added', 'final') if k in data}
        if truncated is not None:
            res.summary['input_truncated'] = str(truncated)
        res.finding = discrepancy_finding(data)

    return work


def discrepancy_finding(data: Mapping[str, object]) -> str:
    """Summarise a discrepancy result in one line.

    ``data`` is the mapping of :func:`tribo_estimation.core.discrepancy.report.to_dict`;
    the line names the effects found, their values and the torque residual RMS [N m]
    before and after.
    """
    added = as_list(data.get('added') or [])
    base = as_mapping(data.get('baseline') or {}).get('rms')
    final = as_mapping(data.get('final') or {}).get('rms')
    rms = f'torque residual RMS {fmt(base, 3)} -> {fmt(final, 3)} N m'
    if not added:
        return f'no missing effect found ({rms})'
    parts = []
    for item in added:
        a = as_mapping(item)
        units = as_mapping(a.get('units') or {})
        params = ', '.join(
            f'{k} = {fmt(v, 3)} {str(units.get(k, "")).strip("-")}'.rstrip()
            for k, v in as_mapping(a.get('params') or {}).items()
        )
        parts.append(f'{a.get("effect")} ({params})')
    return f'found {"; ".join(parts)}; {rms}'
