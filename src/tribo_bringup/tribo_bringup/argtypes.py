"""argparse value types with bounds: a bad option value is one argparse line, exit 2.

``float`` alone accepts ``nan``, ``inf`` and ``1e308``; these types accept only
finite numbers inside the stated range, so no command starts a loop or an
array from an absurd value (``--duration 1e308``, ``--rate 1e-300``).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from typing import TypeAlias

#: The ``add_subparsers`` action each command module's ``register`` adds its parser to.
Subparsers: TypeAlias = 'argparse._SubParsersAction[argparse.ArgumentParser]'


def bounded_float(
    lo: float, hi: float, *, lo_open: bool = False, zero_ok: bool = False, unit: str = ''
) -> Callable[[str], float]:
    """Make an argparse type accepting a finite float in ``[lo, hi]`` (``(lo, hi]`` if ``lo_open``).

    ``zero_ok`` additionally admits exactly 0 (e.g. "0: as fast as possible");
    ``unit`` names the unit in the error message.
    """
    u = f' {unit}' if unit else ''

    def parse(text: str) -> float:
        try:
            x = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f'{text!r} is not a number') from None
        if zero_ok and x == 0.0:
            return 0.0
        low_ok = x > lo if lo_open else x >= lo
        if not (math.isfinite(x) and low_ok and x <= hi):
            left = '(' if lo_open else '['
            extra = ' or 0' if zero_ok else ''
            raise argparse.ArgumentTypeError(f'{text} is outside {left}{lo:g}, {hi:g}]{u}{extra}')
        return x

    parse.__name__ = 'number'
    return parse


def bounded_int(lo: int, hi: int) -> Callable[[str], int]:
    """Type accepting an integer in ``[lo, hi]``."""

    def parse(text: str) -> int:
        try:
            x = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f'{text!r} is not an integer') from None
        if not lo <= x <= hi:
            raise argparse.ArgumentTypeError(f'{text} is outside [{lo}, {hi}]')
        return x

    parse.__name__ = 'integer'
    return parse
