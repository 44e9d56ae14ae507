"""The replay-test harness: a node under test, `tribo record` and `tribo replay`.

Shared by the bag-replay tests (``test_record_replay``, ``test_friction_replay``,
``test_model_monitor_replay``). Every process goes into the test's ``procs`` list
(stopped at the end) and logs to ``<name>.log`` in the test's directory.
"""

from __future__ import annotations

import shutil
from collections.abc import Sequence
from pathlib import Path

from support import ROOT, Proc, tribo_cmd, wait_for

#: How long a process may take to start (the numba kernel may compile) [s].
START_TIMEOUT = 120.0


def start_node(
    procs: list[Proc], log_dir: Path, executable: str, params_file: str, ready: str
) -> Proc:
    """Start a node executable with ``config/<params_file>``; wait for its ``ready`` line."""
    node = Proc(
        [
            shutil.which(executable) or executable,
            '--ros-args',
            '--params-file',
            str(ROOT / 'config' / params_file),
        ],
        log_dir / 'node.log',
    )
    procs.append(node)
    assert wait_for(
        lambda: ready in node.output() or node.popen.poll() is not None, START_TIMEOUT
    ), node.output()
    assert node.popen.poll() is None, node.output()
    return node


def start_recorder(
    procs: list[Proc],
    log_dir: Path,
    out: Path,
    topics: Sequence[str],
    *extra: str,
    matched: Sequence[str] = (),
    command: Sequence[str] | None = None,
) -> Proc:
    """Start `tribo record --out OUT --topics ...` (or ``command``, the same arguments).

    With ``matched``, wait until the recorder logs that its subscription to each of
    those topics has matched a publisher.
    """
    args = ['record', '--out', str(out), '--topics', *topics, *extra]
    rec = Proc([*command, *args] if command is not None else tribo_cmd(*args), log_dir / 'rec.log')
    procs.append(rec)
    if matched:
        assert wait_for(
            lambda: (
                all(f'recording {t} ' in rec.output() for t in matched)
                or rec.popen.poll() is not None
            ),
            START_TIMEOUT,
        ), rec.output()
        assert rec.popen.poll() is None, rec.output()
    return rec


def start_replay(
    procs: list[Proc], log_dir: Path, bag: Path, rate: float, wait_subscribers: float = 60.0
) -> Proc:
    """Start `tribo replay BAG --rate RATE` once ``wait_subscribers`` [s] allow a match."""
    rep = Proc(
        tribo_cmd(
            'replay', str(bag), '--rate', f'{rate:g}', '--wait-subscribers', f'{wait_subscribers:g}'
        ),
        log_dir / 'replay.log',
    )
    procs.append(rep)
    return rep


def replay(
    procs: list[Proc], log_dir: Path, bag: Path, rate: float, wait_subscribers: float = 60.0
) -> None:
    """Replay a bag to its end (:func:`start_replay`, then a clean exit within 120 s).

    The replay must have found its subscribers before it published (else the test
    would wait for data that went nowhere: DDS discovery failed).
    """
    rep = start_replay(procs, log_dir, bag, rate, wait_subscribers)
    assert rep.wait(120) == 0, rep.output()
    assert 'publishing anyway' not in rep.output(), rep.output()
