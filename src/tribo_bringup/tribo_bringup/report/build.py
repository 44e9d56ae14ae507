"""Assemble the session report: scan the bag, run the analyses, write page and results."""

from __future__ import annotations

import json
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

from tribo_bringup.analyses import AnalysisInputs
from tribo_bringup.errors import BagError, ConfigError
from tribo_bringup.outputs import atomic_output_dir
from tribo_estimation.errors import EstimationError

from . import analyses as an
from .page import Section, clean_json, render_html
from .provenance import provenance
from .scan import scan_bag
from .sections import (
    analysis_section,
    friction_section,
    monitor_section,
    rig_section,
    session_section,
    summary_lines,
    wear_section,
)

if TYPE_CHECKING:
    from tribo_estimation.core.model import RigParams
    from tribo_nvct.core.config import NvctConfig

Progress = an.Progress


def load_rig(path: str | Path | None) -> dict[str, object]:
    """Read RIG.yaml as a mapping (empty when ``path`` is None).

    Raises
    ------
    ConfigError
        The file is unreadable, not YAML or not a mapping.
    """
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


def load_nvct(path: str | Path | None) -> NvctConfig | None:
    """Load the run's NvctConfig (tribo_nvct's loader), or None when not given."""
    if path is None:
        return None
    from tribo_nvct.core.config import load_config

    return load_config(path)


@dataclass(frozen=True)
class ReportResult:
    """Where the report went and what it says."""

    html: Path
    results: dict[str, Any]
    summary: list[str]


def _rig_params(rig: str | Path | None) -> tuple[RigParams | None, str]:
    """Rig parameters for the stick detection of the motion detail, or None and why."""
    if rig is None:
        return None, 'no RIG.yaml given (--rig)'
    from tribo_estimation.core.config import load_rig_config

    try:
        return load_rig_config(rig).rig, ''
    except EstimationError as exc:
        return None, f'rig parameters unusable: {exc}'


def _run_analyses(
    todo: Sequence[str],
    inputs: AnalysisInputs,
    stage: Path,
    counts: Mapping[str, int],
    notes: Mapping[str, str],
    say: Progress,
) -> list[an.AnalysisOutcome]:
    """Run the registered analyses ``todo`` whose inputs are there (:mod:`..analyses`)."""
    from tribo_bringup import analyses

    out: list[an.AnalysisOutcome] = []
    for key in todo:
        analysis = analyses.get(key)
        reason = analyses.missing(analysis, inputs, counts)
        if reason:
            out.append(an.failed(key, reason))
        else:
            out.append(an.run_analysis(analysis, inputs, stage, say, notes.get(key, '')))
    return out


def _offline_blocks(outcomes: Sequence[an.AnalysisOutcome]) -> list[dict[str, object]]:
    """Return the offline block fit's blocks as /friction/estimate dicts (none if it failed)."""
    from tribo_bringup import bridge_core as bc
    from tribo_estimation.results import BlockFit

    for res in outcomes:
        if res.key == 'friction' and res.ok and isinstance(res.result, BlockFit):
            return [an.block_estimate(r, bc.FRICTION_FIELDS) for r in res.result.results]
    return []


def build_report(
    bag: str | Path,
    out: str | Path,
    *,
    rig: str | Path | None = None,
    nvct: str | Path | None = None,
    discrepancy: bool = False,
    discrepancy_window: tuple[float, float] = (0.0, 0.0),
    analysis_rig: str | Path | None = None,
    analyses: Sequence[str] | None = None,
    notes: Mapping[str, str] | None = None,
    command: Sequence[str] | None = None,
    progress: Progress | None = None,
) -> ReportResult:
    """Write the session report of ``bag`` into directory ``out``.

    Parameters
    ----------
    bag
        recorded bag (directory or .mcap).
    out
        output directory (written atomically: on an error it keeps what it held).
    rig
        RIG.yaml of the run (rig parameter table; rig parameters of the stick detection).
    nvct
        NVCT.yaml (wear analysis, k_w).
    discrepancy
        also run the discrepancy workflow on the bag.
    discrepancy_window
        (start, duration) [s] of the rig streams the discrepancy
        workflow analyses, from the first sample (duration 0: to the end).
    analysis_rig
        RIG.yaml given to the analyses (default ``rig``); e.g. the nominal
        rig without the hidden effects the simulated rig ran with.
    analyses
        registered analyses to run (:mod:`tribo_bringup.analyses`; default: every one
        not ``on_request``, i.e. ``friction`` and ``wear``).
    notes
        a note per analysis shown in its section (e.g. analysed window).
    command
        the command line to record (default ``sys.argv``).
    progress
        callback for progress lines (default: stderr).

    Raises
    ------
    BagError
        the bag does not exist or holds no known message.
    ConfigError, EstimationError, NvctError
        RIG.yaml or NVCT.yaml unreadable.
    """
    say = progress or (lambda s: print(f'report: {s}', file=sys.stderr, flush=True))
    bag_p = Path(bag)
    out_p = Path(out)
    if not bag_p.exists():
        raise BagError(f'{bag_p}: no such bag')
    rig_s = str(rig) if rig is not None else None
    rig_data = load_rig(rig)
    nvct_cfg = load_nvct(nvct)
    say(f'reading {bag_p}')
    scan = scan_bag(bag_p)
    rig_params, rig_note = _rig_params(rig)
    from tribo_bringup import analyses as registry

    chosen = registry.defaults() if analyses is None else analyses
    todo = [a for a in chosen if a in registry.MODULES]
    if discrepancy and 'discrepancy' not in todo:
        todo.append('discrepancy')
    a_rig = analysis_rig if analysis_rig is not None else rig
    inputs = AnalysisInputs(
        bag_p,
        Path(a_rig) if a_rig is not None else None,
        Path(nvct) if nvct is not None else None,
        discrepancy_window,
        say,
    )
    results: dict[str, Any] = {'analyses': {}}
    with atomic_output_dir(out_p) as stage:
        sections: list[Section] = [
            session_section(bag_p, scan, results, stage),
            rig_section(rig_data, rig_s, results),
        ]
        wear_sec = wear_section(scan, nvct_cfg, results, stage)
        outcomes = _run_analyses(todo, inputs, stage, scan.counts, notes or {}, say)
        for res in outcomes:
            results['analyses'][res.key] = res.status()
        if scan.estimates:
            ests, source = scan.estimates, 'live estimator, /friction/estimate'
        else:
            ests, source = _offline_blocks(outcomes), 'offline fit, tribo friction'
        say('friction section and plots')
        sections += friction_section(ests, source, results, stage, bag_p, rig_params, rig_note)
        sections.append(wear_sec)
        mon_sec = monitor_section(scan, results, stage)
        if mon_sec is not None:
            sections.append(mon_sec)
        sections += [analysis_section(r, registry.get(r.key).title) for r in outcomes]
        prov = provenance(command)
        results['provenance'] = prov
        summary = summary_lines(results)
        results['summary'] = summary
        (stage / 'results.json').write_text(
            json.dumps(clean_json(results), indent=2, allow_nan=False) + '\n', encoding='utf-8'
        )
        page = render_html(f'tribo session report: {bag_p.name}', summary, sections, prov)
        (stage / 'report.html').write_text(page, encoding='utf-8')
    html_path = out_p / 'report.html'
    say(f'wrote {html_path}')
    return ReportResult(html_path, results, summary)
