"""Write a benchmark's printed figures into its section of ``docs/validation.md``.

A benchmark that prints accuracy figures ends with ``sys.exit(run(__file__, main))``:
its output goes to the terminal as always and, when ``make bench`` runs it (the
environment variable :data:`WRITE_ENV` set to 1), also into ``docs/validation.md``
between the markers ``<!-- bench_NAME: begin -->`` and ``<!-- bench_NAME: end -->``
with the date, the commit and the command. A section that is not there yet is
appended at the end. Nothing is written when the benchmark raises.
"""

from __future__ import annotations

import datetime
import io
import os
import shlex
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TextIO

ROOT = Path(__file__).resolve().parents[1]

#: The validation page the figures go to.
DOC = ROOT / 'docs' / 'validation.md'

#: Set to 1 (``make bench`` does) to write the figures into :data:`DOC`.
WRITE_ENV = 'TRIBO_WRITE_VALIDATION'


def begin_marker(name: str) -> str:
    """Return the marker that opens benchmark ``name``'s section."""
    return f'<!-- {name}: begin -->'


def end_marker(name: str) -> str:
    """Return the marker that closes benchmark ``name``'s section."""
    return f'<!-- {name}: end -->'


def replace_section(text: str, name: str, body: str) -> str:
    """Return ``text`` with benchmark ``name``'s section replaced by ``body``.

    Parameters
    ----------
    text : str
        The page.
    name : str
        Benchmark name (``bench_friction``).
    body : str
        The new content between the markers.

    Returns
    -------
    str
        The page; the section (with a heading) is appended if the page has none.

    Raises
    ------
    ValueError
        If a marker is there more than once, or the end marker is missing or
        comes before the begin marker.
    """
    begin, end = begin_marker(name), end_marker(name)
    n_begin, n_end = text.count(begin), text.count(end)
    if n_begin == n_end == 0:
        return f'{text.rstrip()}\n\n## {name}\n\n{begin}\n{body.rstrip()}\n{end}\n'
    if n_begin != 1 or n_end != 1 or text.index(end) < text.index(begin):
        raise ValueError(f'{DOC.name}: the markers of {name} must appear once each, in order')
    head, rest = text.split(begin, 1)
    _, tail = rest.split(end, 1)
    return f'{head}{begin}\n{body.rstrip()}\n{end}{tail}'


def section_body(output: str, command: str, date: str, commit: str) -> str:
    """Return the Markdown of one section: where the figures come from, then the output.

    Parameters
    ----------
    output : str
        What the benchmark printed.
    command : str
        The command line that ran it.
    date : str
        ISO date of the run.
    commit : str
        Commit the run was made on (``''``: unknown).

    Returns
    -------
    str
        The section's content.
    """
    at = f' at commit `{commit}`' if commit else ''
    return f'Written by `make bench` on {date}{at}: `{command}`\n\n```\n{output.rstrip()}\n```\n'


def _commit() -> str:
    """Return the short hash of HEAD, with ``+`` if the tree has changes ('' without git)."""
    try:
        head = subprocess.run(
            ['git', 'rev-parse', '--short', 'HEAD'], cwd=ROOT, capture_output=True, text=True
        )
        dirty = subprocess.run(
            ['git', 'status', '--porcelain', '--untracked-files=no'],
            cwd=ROOT,
            capture_output=True,
            text=True,
        )
    except OSError:
        return ''
    if head.returncode != 0:
        return ''
    return head.stdout.strip() + ('+' if dirty.stdout.strip() else '')


def _exit_code(result: object) -> int:
    """Return a benchmark main's exit code (its int result; 0 for anything else)."""
    return result if isinstance(result, int) and not isinstance(result, bool) else 0


class _Tee(io.TextIOBase):
    """A text stream that writes to ``out`` and keeps a copy."""

    def __init__(self, out: TextIO) -> None:
        self.out = out
        self.copy = io.StringIO()

    def write(self, s: str) -> int:
        self.out.write(s)
        self.copy.write(s)
        return len(s)

    def flush(self) -> None:
        self.out.flush()


def run(script: str, main: Callable[[], object]) -> int:
    """Run a benchmark's ``main``; with :data:`WRITE_ENV` set, write its output to :data:`DOC`.

    Parameters
    ----------
    script : str
        The benchmark's ``__file__`` (its stem names the section).
    main : Callable[[], object]
        The benchmark; an int it returns is its exit code (anything else: 0).

    Returns
    -------
    int
        ``main``'s exit code (the section notes a non-zero one).
    """
    if os.environ.get(WRITE_ENV) != '1':
        return _exit_code(main())
    name = Path(script).stem
    tee = _Tee(sys.stdout)
    sys.stdout = tee
    try:
        code = _exit_code(main())
    finally:
        sys.stdout = tee.out
    output = tee.copy.getvalue()
    if code:
        output += f'\n(exit code {code})'
    command = shlex.join(['python', f'bench/{Path(script).name}', *sys.argv[1:]])
    date = datetime.date.today().isoformat()
    text = DOC.read_text(encoding='utf-8') if DOC.is_file() else '# Validation\n'
    DOC.write_text(
        replace_section(text, name, section_body(output, command, date, _commit())),
        encoding='utf-8',
    )
    print(f'{name}: figures written to {DOC}', file=sys.stderr)
    return code
