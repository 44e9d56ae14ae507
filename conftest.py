"""Test-session settings shared by every test directory of the workspace.

Tests that use DDS run on their own ROS_DOMAIN_ID (11-40, varied by the
process id so that parallel runs of the suite on one machine rarely meet; a
pytest-xdist worker N is moved by 30*(N mod 3), so workers 0-2 stay within
11-100: a domain above 101 has ports in Linux's ephemeral range) with
localhost-only discovery.
"""

from __future__ import annotations

import functools
import os
import signal
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

if TYPE_CHECKING:
    from tribo_estimation.core.simulate import SimResult

#: The repository root.
REPO = Path(__file__).resolve().parent

try:  # property-based suite (tests/test_fuzz_*.py): HYPOTHESIS_PROFILE=ci (default) or fuzz
    from hypothesis import HealthCheck, settings

    _quiet_checks = [HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much]
    # ci: a few examples per command (the whole fuzz suite in ~30 s), reproducible
    settings.register_profile(
        'ci',
        max_examples=4,
        deadline=None,
        derandomize=True,
        database=None,
        suppress_health_check=_quiet_checks,
    )
    # fuzz (make fuzz): 10,000 generated bad inputs per command
    settings.register_profile(
        'fuzz', max_examples=10_000, deadline=None, suppress_health_check=_quiet_checks
    )
    settings.load_profile(os.environ.get('HYPOTHESIS_PROFILE', 'ci'))
    if os.environ.get('HYPOTHESIS_MAX_EXAMPLES', '').isdigit():  # e.g. a shorter fuzz run
        settings.register_profile(
            'custom', settings(max_examples=int(os.environ['HYPOTHESIS_MAX_EXAMPLES']))
        )
        settings.load_profile('custom')
except ImportError:  # hypothesis is pinned in requirements.txt; tolerate its absence
    pass

_worker = os.environ.get('PYTEST_XDIST_WORKER', 'gw0')
_index = int(_worker[2:]) if _worker.startswith('gw') and _worker[2:].isdigit() else 0
os.environ['ROS_DOMAIN_ID'] = str(11 + 30 * (_index % 3) + os.getpid() % 30)
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'


@functools.cache
def _simulated(rig: str, duration: float, fs: float, noise: bool, seed: int) -> SimResult:
    import tribo_estimation as te

    return te.simulate(REPO / 'config' / rig, duration, fs=fs, noise=noise, seed=seed)


@pytest.fixture(scope='session')
def sim_record() -> Callable[..., SimResult]:
    """Return the one factory of simulated rig records for the tests (cached per process).

    ``sim_record(duration=3.0, fs=10_000.0, *, rig='rig.yaml', noise=True, seed=1)``
    simulates ``config/<rig>`` (a ``SimResult``: a ``RigRecord`` plus the truth). The
    same arguments return the same object: copy an array before changing it.
    """

    def make(
        duration: float = 3.0,
        fs: float = 10_000.0,
        *,
        rig: str = 'rig.yaml',
        noise: bool = True,
        seed: int = 1,
    ) -> SimResult:
        return _simulated(rig, float(duration), float(fs), bool(noise), int(seed))

    return make


@pytest.fixture(autouse=True)
def _sigint_restored() -> Iterator[None]:
    """Give SIGINT a handler before and its handler back after each test (main thread).

    The graph runner ignores a second Ctrl-C while it shuts down, for good; a test
    that runs it in the worker process would otherwise leave SIGINT ignored, and every
    process the worker starts later inherits that (a test's Ctrl-C then stops nothing).
    """
    main = threading.current_thread() is threading.main_thread()
    if main and signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        # left ignored before this test (outside any test): Python's own handler
        signal.signal(signal.SIGINT, signal.default_int_handler)
    before = signal.getsignal(signal.SIGINT) if main else None
    yield
    if main and signal.getsignal(signal.SIGINT) is not before and before is not None:
        signal.signal(signal.SIGINT, before)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Queue the tests marked ``slow`` first (a stable sort, the order otherwise kept).

    pytest-xdist hands the tests out in collection order: a long test started last would
    keep one worker busy after the others ran out of work; started first, the short tests
    fill the other workers around it.
    """
    items.sort(key=lambda item: item.get_closest_marker('slow') is None)
