"""Session report: one self-contained HTML page plus CSV/JSON results for a recorded bag.

:func:`build_report` reads a bag of the tribo graph and writes into ``out``
(atomically, through :func:`tribo_bringup.outputs.atomic_output_dir`):

- ``report.html``: one page, plots embedded as base64 PNG, inline CSS, no
  script and no network access needed to view it;
- ``results.json``: every number shown on the page (SI units; keys name the unit
  where it is not SI) plus the provenance (command line, versions, git commit);
- ``friction_blocks.csv``: the per-block friction estimates (live ones recorded on
  ``/friction/estimate``, else the offline fit; paper section 2.5, Equ. 8);
- ``wear_states.csv``: the live nVCT wear states recorded on ``/nvct/wear``
  (paper section 3, Equ. 8-10);
- ``streams.csv``: sample continuity of every SampleBlock topic;
- ``analyses/<name>/``: the outputs of the offline analyses (block fit, nVCT
  evaluation, discrepancy workflow), the registered analyses of
  :mod:`tribo_bringup.analyses`, run in this process through the Python API their
  commands are shells over (:mod:`.analyses` runs them).

A section whose input is missing (topic not in the bag, an analysis failing) is
shown as unavailable with the reason; the report itself never fails because of
one section. Figures follow the paper: Fig. 4/5 (mu0, mu_inf per block with the
torsion-moment envelope), Fig. 6 (torsion-moment detail with the stick phases of
:func:`tribo_estimation.core.sticks.detect_sticks`), Fig. 10/11 (wear volume over
test time; :mod:`tribo_nvct.plots`).

Modules: :mod:`.scan` (bag scan), :mod:`.analyses` (offline analyses),
:mod:`.sections` (the page's sections and summary), :mod:`.page` (HTML),
:mod:`.provenance` (versions, git commit), :mod:`.build` (:func:`build_report`).
"""

from __future__ import annotations

from .analyses import AnalysisOutcome
from .build import ReportResult, build_report, load_rig
from .page import clean_json, fmt
from .provenance import git_state, provenance
from .scan import BagScan, RigWindow, read_rig_window, scan_bag, stick_flags
from .sections import DETAIL_S, UM3, analysis_section, block_table, detail_trace, summary_lines

__all__ = [
    'DETAIL_S',
    'UM3',
    'AnalysisOutcome',
    'BagScan',
    'ReportResult',
    'RigWindow',
    'analysis_section',
    'block_table',
    'build_report',
    'clean_json',
    'detail_trace',
    'fmt',
    'git_state',
    'load_rig',
    'provenance',
    'read_rig_window',
    'scan_bag',
    'stick_flags',
    'summary_lines',
]
