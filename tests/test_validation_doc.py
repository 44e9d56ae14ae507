"""docs/validation.md is written by the benchmarks (bench/validation_doc.py), one marked
section per benchmark; the helper replaces exactly that section."""

from __future__ import annotations

import importlib.util
import re
import sys
from pathlib import Path
from types import ModuleType

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _helper() -> ModuleType:
    spec = importlib.util.spec_from_file_location(
        'validation_doc', ROOT / 'bench' / 'validation_doc.py'
    )
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


vd = _helper()

PAGE = (
    '# Validation\n\nintro\n\n## bench_a\n\n<!-- bench_a: begin -->\nold a\n'
    '<!-- bench_a: end -->\n\n## bench_b\n\n<!-- bench_b: begin -->\nold b\n<!-- bench_b: end -->\n'
)


def test_replace_section_changes_only_that_section() -> None:
    out = vd.replace_section(PAGE, 'bench_a', 'new a\n')
    assert out == PAGE.replace('old a', 'new a')
    # idempotent: the same body again gives the same page
    assert vd.replace_section(out, 'bench_a', 'new a\n') == out


def test_a_new_benchmark_gets_a_section_at_the_end() -> None:
    out = vd.replace_section(PAGE, 'bench_c', 'figures')
    assert out.startswith(PAGE.rstrip())
    assert out.endswith('## bench_c\n\n<!-- bench_c: begin -->\nfigures\n<!-- bench_c: end -->\n')


@pytest.mark.parametrize(
    'page',
    [
        '<!-- bench_a: begin -->\nx\n',  # no end
        '<!-- bench_a: end -->\nx\n<!-- bench_a: begin -->\n',  # out of order
        PAGE + '<!-- bench_a: begin -->\n',  # twice
    ],
)
def test_broken_markers_are_refused(page: str) -> None:
    with pytest.raises(ValueError, match='bench_a'):
        vd.replace_section(page, 'bench_a', 'y')


def test_run_writes_output_date_commit_and_command_only_when_asked(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    doc = tmp_path / 'validation.md'
    doc.write_text(PAGE)
    monkeypatch.setattr(vd, 'DOC', doc)
    monkeypatch.setattr(sys, 'argv', ['bench_a.py', '--quick'])

    def main() -> int:
        print('mu0 error 0.01 %')
        return 0

    monkeypatch.delenv(vd.WRITE_ENV, raising=False)
    assert vd.run('bench/bench_a.py', main) == 0
    assert doc.read_text() == PAGE  # a plain run leaves the page alone
    monkeypatch.setenv(vd.WRITE_ENV, '1')
    assert vd.run('bench/bench_a.py', main) == 0
    text = doc.read_text()
    section = text.split('<!-- bench_a: begin -->')[1].split('<!-- bench_a: end -->')[0]
    assert re.search(r'on \d{4}-\d{2}-\d{2}', section)
    assert '`python bench/bench_a.py --quick`' in section
    assert '```\nmu0 error 0.01 %\n```' in section
    assert 'old b' in text  # the other section is untouched
    assert 'mu0 error 0.01 %' in capsys.readouterr().out  # still printed


def test_every_recording_benchmark_has_its_section() -> None:
    page = (ROOT / 'docs' / 'validation.md').read_text()
    recording = sorted(
        p.stem
        for p in (ROOT / 'bench').glob('bench_*.py')
        if 'validation_doc.run(' in p.read_text()
    )
    assert len(recording) >= 8, recording
    for name in recording:
        how = (
            f'docs/validation.md needs one section for {name}: a heading, what it shows, and '
            f'the markers {vd.begin_marker(name)} ... {vd.end_marker(name)}'
        )
        assert page.count(vd.begin_marker(name)) == 1, how
        assert page.count(vd.end_marker(name)) == 1, how
