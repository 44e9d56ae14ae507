"""The ``tribo`` command: one entry point, one subcommand per job.

Each subcommand lives in :mod:`tribo_bringup.commands` as a module exposing
``register(subparsers)``; the module adds its parser and sets
``func=<callable(args) -> int>``. Bad input raised as one of the packages'
specific errors (or ``ValueError``/``OSError``) is answered with one line on
stderr and exit code 2; no traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

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


def _error_types() -> tuple[type[BaseException], ...]:
    """Collect the packages' base error classes (each package has one errors.py)."""
    types: list[type[BaseException]] = [ValueError, OSError, KeyError]
    for mod_name, cls_name in (
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


def build_parser() -> argparse.ArgumentParser:
    """Build the argument parser with every available subcommand."""
    parser = argparse.ArgumentParser(
        prog='tribo',
        description='Model-assisted tribometry on a ROS 2 graph: stick-slip friction '
        'estimation and nVCT wear measurement.',
    )
    sub = parser.add_subparsers(dest='command', metavar='COMMAND')
    sub.required = True
    for name in COMMANDS:
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
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        print(f'tribo {args.command}: interrupted', file=sys.stderr)
        return 130
    except _error_types() as exc:
        msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        if isinstance(exc, KeyError):
            msg = f'missing key {msg}'
        print(f'tribo {args.command}: error: {msg}', file=sys.stderr)
        return EXIT_BAD_INPUT


if __name__ == '__main__':
    sys.exit(main())
