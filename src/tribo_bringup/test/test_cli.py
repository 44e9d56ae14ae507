"""The tribo command: its parser, and imports only where a command runs."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from tribo_bringup.cli import COMMANDS, build_parser, main

REPO = Path(__file__).resolve().parents[3]

#: Imported by no ``--help``: they belong to the commands' runs.
HEAVY = ('numba', 'scipy', 'matplotlib', 'pandas', 'rclpy', 'tribo_estimation.core.discrepancy')


def test_help_lists_every_command(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as done:
        main(['--help'])
    assert done.value.code == 0
    out = capsys.readouterr().out
    for name in COMMANDS:
        assert f'    {name}' in out, name


def test_a_command_line_builds_its_command_alone() -> None:
    parser = build_parser('friction')
    args = parser.parse_args(['friction', 'run.csv', '--rig', 'r.yaml', '--out', 'o'])
    assert (args.command, args.block, args.no_plots) == ('friction', 1.0, False)
    with pytest.raises(SystemExit):
        parser.parse_args(['wear', 'c.csv'])  # not registered in this parser


def test_help_imports_nothing_heavy() -> None:
    """``tribo --help`` and every ``tribo CMD --help`` parse without the libraries their
    commands run on (the CPU times: bench/bench_cli.py)."""
    code = (
        'import sys\n'
        'from tribo_bringup.cli import main\n'
        'try:\n'
        '    main(sys.argv[1:])\n'
        'except SystemExit:\n'
        '    pass\n'
        f'print(sorted(m for m in {HEAVY!r} if m in sys.modules))\n'
    )
    for cmd in ('', *COMMANDS):
        argv = [sys.executable, '-c', code, *([cmd] if cmd else []), '--help']
        out = subprocess.run(argv, capture_output=True, text=True, check=True)
        assert out.stdout.strip().splitlines()[-1] == '[]', (cmd, out.stdout[-300:])


def test_list_candidates_prints_the_registry(capsys: pytest.CaptureFixture[str]) -> None:
    from tribo_estimation.core.discrepancy import candidates

    with pytest.raises(SystemExit) as done:
        main(['discrepancy', '--list-candidates'])
    assert done.value.code == 0
    out = capsys.readouterr().out
    for c in candidates.all_candidates():
        assert c.description in out, c.name


def test_friction_imports_only_what_it_runs(tmp_path: Path) -> None:
    """``tribo friction --no-plots`` loads neither the discrepancy package, matplotlib,
    pandas nor scipy.signal/stats (the block fit needs none of them)."""
    import tribo_estimation as te

    csv = te.simulate(REPO / 'config' / 'rig.yaml', 1.2).write(tmp_path / 'r.csv')
    unused = (
        'tribo_estimation.core.discrepancy', 'matplotlib', 'pandas', 'scipy.signal',
        'scipy.stats', 'rclpy',
    )  # fmt: skip
    code = (
        'import sys\n'
        'from tribo_bringup.cli import main\n'
        'assert main(sys.argv[1:]) == 0\n'
        f'print(sorted(m for m in {unused!r} if m in sys.modules))\n'
    )
    argv = [sys.executable, '-c', code, 'friction', str(csv), '--rig',
            str(REPO / 'config' / 'rig.yaml'), '--out', str(tmp_path / 'o'), '--no-plots',
            '--quiet']  # fmt: skip
    out = subprocess.run(argv, capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == '[]', out.stdout[-300:]
