"""The README's Python example runs as written (a doctest on a small simulated record)."""

from __future__ import annotations

import doctest
import re
from pathlib import Path

import pytest
from support import ROOT


def _python_blocks(text: str) -> list[str]:
    return re.findall(r'```python\n(.*?)```', text, flags=re.S)


def test_readme_python_example_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    blocks = _python_blocks((ROOT / 'README.md').read_text(encoding='utf-8'))
    assert len(blocks) == 1, 'the README has one Python example'
    example = blocks[0]
    assert 5 <= sum(line.startswith('>>> ') for line in example.splitlines()) <= 10
    (tmp_path / 'config').symlink_to(ROOT / 'config')  # the example runs from the repo root
    monkeypatch.chdir(tmp_path)
    test = doctest.DocTestParser().get_doctest(example, {}, 'README.md', 'README.md', 0)
    runner = doctest.DocTestRunner(optionflags=doctest.NORMALIZE_WHITESPACE)
    runner.run(test)
    result = runner.summarize(verbose=False)
    assert result.attempted >= 5 and result.failed == 0, result
    # the files the example says it writes are there
    assert sorted(p.name for p in (tmp_path / 'fric').iterdir()) == [
        'blocks.csv', 'blocks.png', 'detail.png', 'mu_slip.png',
    ]  # fmt: skip
