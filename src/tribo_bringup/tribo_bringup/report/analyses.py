"""Running the session's offline analyses for the report (never taking it down).

The analyses themselves are registered in :mod:`tribo_bringup.analyses` (one
protocol: name, inputs, run, write, summary, finding); :func:`run_analysis` runs
one of them into ``analyses/<name>/`` of the report and returns an
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

if TYPE_CHECKING:
    from tribo_bringup.analyses import Analysis, AnalysisInputs, AnalysisResult
    from tribo_estimation.core.blockfit import BlockResult

Progress = Callable[[str], None]


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
    result
        the analysis' result (None when it failed).
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
    result: AnalysisResult | None = None
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
    analysis: Analysis, inp: AnalysisInputs, out: Path, progress: Progress, note: str = ''
) -> AnalysisOutcome:
    """Run a registered analysis into ``out/analyses/<name>``.

    Never raises: a failure is recorded in the outcome.

    Parameters
    ----------
    analysis : Analysis
        The analysis (:mod:`tribo_bringup.analyses`).
    inp : AnalysisInputs
        The session and the configs.
    out : Path
        The report directory.
    progress : callable
        Receives progress lines.
    note : str
        Shown with the section.

    Returns
    -------
    AnalysisOutcome
        Its results, or why it failed.
    """
    from tribo_bringup.analyses import write

    key = analysis.name
    rel = Path('analyses') / key
    res = AnalysisOutcome(key, directory=str(rel), note=note, what=analysis.call(inp))
    t0 = time.monotonic()
    progress(f'{key}: running')
    try:
        d = out / rel
        d.mkdir(parents=True, exist_ok=True)
        result = analysis.run(inp)
        res.files, res.figures = write(result, d)
        res.summary = analysis.summary(result)
        res.finding = analysis.finding(result)
        res.result = result
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
