"""tribo_bringup.analyses: one protocol, one registry, the commands' numbers."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from tribo_bringup import analyses
from tribo_bringup.analyses import AnalysisInputs
from tribo_estimation.core.record import RigRecord

REPO = Path(__file__).resolve().parents[4]
RIG = REPO / 'config' / 'rig.yaml'


def test_registry_holds_one_module_per_analysis() -> None:
    assert analyses.names() == ('friction', 'wear', 'discrepancy')
    for name in analyses.names():
        a = analyses.get(name)
        assert a.name == name and a.title and a.inputs
        for method in ('call', 'run', 'summary', 'finding'):
            assert callable(getattr(a, method)), (name, method)
    with pytest.raises(KeyError):
        analyses.get('nothing')
    # a report runs every registered analysis not on request: the long one is asked for
    assert analyses.defaults() == ('friction', 'wear')
    assert analyses.get('discrepancy').on_request


def test_missing_inputs_are_named() -> None:
    bag = Path('session')
    friction, wear = analyses.get('friction'), analyses.get('wear')
    topics = {'/rig/torsion_moment': 10}
    assert analyses.missing(friction, AnalysisInputs(bag), topics) == 'no RIG.yaml given (--rig)'
    assert analyses.missing(friction, AnalysisInputs(bag, rig=RIG), topics) == ''
    assert analyses.missing(friction, AnalysisInputs(bag, rig=RIG), {}) == (
        'no /rig/torsion_moment in the bag'
    )
    nvct = AnalysisInputs(bag, nvct=REPO / 'config' / 'nvct.yaml')
    assert analyses.missing(wear, AnalysisInputs(bag), topics) == 'no NVCT.yaml given (--nvct)'
    assert analyses.missing(wear, nvct, topics) == 'no /nvct/counts in the bag'


def test_friction_analysis_writes_what_tribo_friction_writes(
    sim_record: Callable[..., RigRecord], tmp_path: Path
) -> None:
    from tribo_bringup.cli import main

    csv = sim_record(3.0).write(tmp_path / 'run.csv')
    a = analyses.get('friction')
    inp = AnalysisInputs(csv, rig=RIG)
    result = a.run(inp)
    files, figures = analyses.write(result, tmp_path / 'a')
    assert [f.name for f in files] == ['blocks.csv']
    assert [f.name for f in figures] == ['blocks.png', 'mu_slip.png', 'detail.png']
    summary = a.summary(result)
    assert (summary['blocks'], summary['blocks_ok'], summary['input_truncated']) == (3, 2, None)
    assert a.call(inp) == 'fit_blocks(run.csv, rig of rig.yaml, block 1 s)'
    assert main(['friction', str(csv), '--rig', str(RIG), '--out', str(tmp_path / 'c'),
                 '--no-plots', '--quiet']) == 0  # fmt: skip
    assert (tmp_path / 'a' / 'blocks.csv').read_text() == (
        tmp_path / 'c' / 'blocks.csv'
    ).read_text()
