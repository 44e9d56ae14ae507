"""Shared fixtures of the tribo_drivers tests (core/ and nodes/ below mirror the package)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from tribo_drivers.core.can_protocol import CanCodec

#: The shipped DBC of the CAN sensor modules.
DBC = Path(__file__).resolve().parents[3] / 'config' / 'tribo.dbc'


@pytest.fixture
def dbc() -> Path:
    """Path of the shipped DBC."""
    return DBC


@pytest.fixture(scope='module')
def codec() -> CanCodec:
    """The codec of the shipped DBC."""
    return CanCodec(DBC)


@pytest.fixture
def dbc_with(tmp_path: Path) -> Callable[[str], Path]:
    """Write config/tribo.dbc without its frame-rate attributes, plus ``extra`` lines."""

    def write(extra: str) -> Path:
        lines = [ln for ln in DBC.read_text().splitlines() if 'TriboFrameRate' not in ln]
        path = tmp_path / 'rates.dbc'
        path.write_text('\n'.join(lines) + '\n' + extra + '\n')
        return path

    return write
