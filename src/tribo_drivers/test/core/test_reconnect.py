"""The reconnect back-off schedule (core/reconnect.py)."""

from __future__ import annotations

import pytest

from tribo_drivers.core.reconnect import Backoff
from tribo_drivers.errors import ConfigError


def test_backoff_schedule() -> None:
    b = Backoff(0.1, 2.0, 1.0)
    assert [b.delay(k) for k in range(7)] == [0.0, 0.1, 0.2, 0.4, 0.8, 1.0, 1.0]
    with pytest.raises(ConfigError):
        Backoff(0.0)
    with pytest.raises(ConfigError):
        Backoff(1.0, 2.0, 0.5)
