"""The ``tribo`` command: one entry point, one subcommand per job.

Each subcommand lives in :mod:`tribo_bringup.commands` as a module exposing
``register(subparsers)``; the module adds its parser and sets
``func=<callable(args) -> int>``. Bad input raised as one of the packages'
specific errors (subclasses of ``CommonError``, ``EstimationError``, ``NvctError``,
``DriverError``, ``BringupError``), a bad option value (argparse) or an
``OSError`` naming a file (missing input, unwritable ``--out``) is answered
with one line on stderr and exit code 2; no traceback. Anything else is a bug:
its traceback is shown with a line asking to report it, exit code 1. Ctrl-C
ends any command with exit code 130 (outputs are written atomically, so
nothing partial is left).
"""

from __future__ import annotations

import argparse
import importlib
import sys
import traceback
from collections.abc import Sequence
from typing import NoReturn

#: Subcommand modules in the order ``tribo --help`` lists them. A module that
#: is missing (work in progress) is skipped, never a crash of the whole CLI.
COMMANDS: tuple[str, ...] = (
    'run',
    'record',
    'replay',
    'simulate',
    'decay',
    'friction',
    'campaign',
    'wear',
    'discrepancy',
    'report',
    'demo',
)

EXIT_BAD_INPUT = 2
EXIT_BUG = 1
EXIT_INTERRUPTED = 130


def _error_types() -> tuple[type[BaseException], ...]:
    """Collect the packages' base error classes (each package has one errors.py)."""
    types: list[type[BaseException]] = []
    for mod_name, cls_name in (
        ('tribo_common.errors', 'CommonError'),
        ('tribo_estimation.errors', 'EstimationError'),
        ('tribo_nvct.errors', 'NvctError'),
        ('tribo_drivers.errors', 'DriverError'),
        ('tribo_bringup.errors', 'BringupError'),
    ):
        try:
            mod = importlib.import_module(mod_name)
        except ImportError:
            continue
        cls = getattr(mod, cls_name, None)
        if isinstance(cls, type) and issubclass(cls, BaseException):
            types.append(cls)
    return tuple(types)


class OneLineParser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line (no usage block), exit code 2."""

    def error(self, message: str) -> NoReturn:
        """Exit with code 2 and the first line of ``message``, pointing to ``--help``."""
        first = message.strip().splitlines()[0] if message.strip() else 'bad arguments'
        self.exit(EXIT_BAD_INPUT, f'{self.prog}: error: {first} (see {self.prog} --help)\n')


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """Build the argument parser with every available subcommand (or just ``only``).

    Parameters
    ----------
    only : str or None
        Register this subcommand alone (the command line names it: the other
        command modules need not be imported).

    Returns
    -------
    argparse.ArgumentParser
        The ``tribo`` parser.
    """
    parser = OneLineParser(
        prog='tribo',
        description='Model-assisted tribometry on a ROS 2 graph: stick-slip friction '
        'estimation and nVCT wear measurement.',
    )
    sub = parser.add_subparsers(dest='command', metavar='COMMAND')
    sub.required = True
    for name in COMMANDS if only is None else (only,):
        try:
            mod = importlib.import_module(f'tribo_bringup.commands.{name}')
        except ModuleNotFoundError as exc:
            if exc.name and exc.name.startswith('tribo_bringup.commands'):
                continue
            raise
        mod.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``tribo`` command; returns the process exit code."""
    args_in = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser(args_in[0] if args_in and args_in[0] in COMMANDS else None)
    try:
        args = parser.parse_args(args_in)
    except KeyboardInterrupt:
        return EXIT_INTERRUPTED
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        print(f'tribo {args.command}: interrupted', file=sys.stderr)
        return EXIT_INTERRUPTED
    except _error_types() as exc:
        print(f'tribo {args.command}: error: {_one_line(exc)}', file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as exc:
        if exc.filename is None:
            return _report_bug(args.command)
        reason = exc.strerror or type(exc).__name__
        print(f'tribo {args.command}: error: {exc.filename}: {reason}', file=sys.stderr)
        return EXIT_BAD_INPUT
    except Exception:
        return _report_bug(args.command)


def _report_bug(command: str) -> int:
    """Print the traceback of the exception being handled and ask for a report."""
    traceback.print_exc()
    print(
        f'tribo {command}: internal error (a bug, not your input): please report it '
        'with the traceback above and the command line',
        file=sys.stderr,
    )
    return EXIT_BUG


def _one_line(exc: BaseException) -> str:
    """Return the first non-empty line of an error message (the class name if empty)."""
    for line in str(exc).splitlines():
        if line.strip():
            return line.strip()
    return type(exc).__name__


if __name__ == '__main__':
    sys.exit(main())
