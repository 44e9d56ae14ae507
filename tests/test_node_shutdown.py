"""Nodes end cleanly on Ctrl-C, also on a repeated one, and refuse bad parameters.

Each node runs as its own process in its own session and gets SIGINT to its
process group twice, 50 ms apart (a terminal's Ctrl-C plus the SIGINT that
``ros2 launch`` forwards), while it is streaming. Uses DDS (own
ROS_DOMAIN_ID, localhost discovery, see the root conftest.py).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from support import ROOT, Proc, requires_ros, wait_for

pytestmark = [requires_ros, pytest.mark.ros]


def _node(module: str, tmp_path: Path, name: str, **params: object) -> Proc:
    args = [sys.executable, '-m', module, '--ros-args']
    for k, v in params.items():
        args += ['-p', f'{k}:={v}']
    return Proc(args, tmp_path / f'{name}.log', env={'TRIBO_ROOT': str(ROOT)})


def _sigint_twice(proc: Proc, timeout: float = 20.0) -> int:
    os.killpg(proc.popen.pid, signal.SIGINT)
    time.sleep(0.05)
    try:
        os.killpg(proc.popen.pid, signal.SIGINT)
    except ProcessLookupError:
        pass
    return proc.wait(timeout)


def _assert_clean(text: str) -> None:
    for bad in ('Traceback', 'KeyboardInterrupt', 'RCLError', 'context is invalid'):
        assert bad not in text, text


@pytest.mark.parametrize('run', range(3))
def test_streaming_daq_driver_ends_cleanly_on_double_sigint(
    tmp_path: Path, procs: list[Proc], run: int
) -> None:
    from tribo_drivers.core.emulators import DaqEmulator

    emu = DaqEmulator(10_000.0)
    emu.start()
    try:
        drv = _node(
            'tribo_drivers.nodes.daq_driver', tmp_path, 'daq',
            port=emu.path, sample_rate=10_000.0, block_size=20,
        )  # fmt: skip
        procs.append(drv)
        assert wait_for(lambda: 'opened' in drv.output(), 30), drv.output()
        time.sleep(0.5 + 0.2 * run)  # streaming 500 blocks/s
        rc = _sigint_twice(drv)
    finally:
        emu.close()
    assert rc == 0, drv.output()
    _assert_clean(drv.output())


def test_wear_monitor_writes_its_state_on_double_sigint(tmp_path: Path, procs: list[Proc]) -> None:
    """The state is written at shutdown (dwells received after the last periodic
    write included), whatever the second SIGINT hits."""
    state = tmp_path / 'wear_state.json'
    det = _node(
        'tribo_drivers.nodes.sim_detector', tmp_path, 'det',
        sim_config=ROOT / 'config' / 'sim_detector.yaml', time_scale=1200.0,
    )  # fmt: skip
    mon = _node(
        'tribo_nvct.nodes.wear_monitor', tmp_path, 'mon',
        nvct_config=ROOT / 'config' / 'nvct.yaml', state_file=state, save_interval_s=60.0,
    )  # fmt: skip
    procs += [det, mon]
    assert wait_for(state.is_file, 60), mon.output() + det.output()
    first = len(json.loads(state.read_text())['dwells'])
    time.sleep(2.0)  # 1200x: a 60 s dwell every 50 ms; not written before the 60 s interval
    assert _sigint_twice(mon) == 0, mon.output()
    _assert_clean(mon.output())
    last = len(json.loads(state.read_text())['dwells'])
    assert last > first, (first, last)


@pytest.mark.parametrize(
    ('module', 'param'),
    [
        ('tribo_drivers.nodes.daq_driver', 'baudrate:=fast'),
        ('tribo_drivers.nodes.counter_driver', 'dwell:=long'),
        ('tribo_drivers.nodes.can_driver', 'bitrate:=[1,2]'),
    ],
)
def test_driver_refuses_a_parameter_of_the_wrong_type(module: str, param: str) -> None:
    r = subprocess.run(
        [sys.executable, '-m', module, '--ros-args', '-p', param],
        capture_output=True, text=True, timeout=60, env={**os.environ, 'TRIBO_ROOT': str(ROOT)},
    )  # fmt: skip
    assert r.returncode == 2, r.stderr
    name = param.split(':=')[0]
    assert 'Traceback' not in r.stderr and f"'{name}'" in r.stderr, r.stderr
    assert r.stderr.strip().count('\n') == 0, r.stderr


def test_tribo_run_ends_cleanly_on_double_sigint(tmp_path: Path, procs: list[Proc]) -> None:
    """The one-process graph: a second Ctrl-C during the shutdown neither cuts it short
    (exit 0, the summary printed) nor loses the wear state."""
    from support import tribo_cmd

    state = tmp_path / 'wear_state.json'
    run = Proc(
        tribo_cmd(
            'run', '--nodes', 'sim_detector', 'wear_monitor', '--wear-state', str(state),
            '--record', str(tmp_path / 'bag'),
        ),
        tmp_path / 'run.log',
    )  # fmt: skip
    procs.append(run)
    assert wait_for(state.is_file, 60), run.output()
    time.sleep(1.0)
    assert _sigint_twice(run, 60) == 0, run.output()
    _assert_clean(run.output())
    assert 'run: recorded' in run.output()
    assert json.loads(state.read_text())['dwells']


def _cpu_seconds(pid: int) -> float:
    """User + system CPU time of a process so far [s] (Linux /proc)."""
    fields = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


@pytest.mark.parametrize('delay', [0.0, 0.3, 0.7])
def test_busy_model_monitor_ends_cleanly_on_sigint(
    tmp_path: Path, procs: list[Proc], delay: float
) -> None:
    """Ctrl-C of a launched graph while the monitor's worker evaluates a window: the
    worker stops before the context is shut down (no publish on an invalid context,
    no traceback, exit 0). A 1 s window every 0.1 s keeps the worker always busy."""
    rig = _node('tribo_drivers.nodes.sim_rig', tmp_path, 'rig', **{'effects.viscous': 0.05})
    mon = Proc(
        [
            sys.executable, '-m', 'tribo_estimation.nodes.model_monitor', '--ros-args',
            '--params-file', str(ROOT / 'config' / 'model_monitor.yaml'),
            '-p', 'window:=1.0', '-p', 'hop:=0.1', '-p', 'time_budget:=0.5',
        ],
        tmp_path / 'mon.log', env={'TRIBO_ROOT': str(ROOT)},
    )  # fmt: skip
    procs += [rig, mon]
    assert wait_for(lambda: 'streaming started' in rig.output(), 120), rig.output()
    # busy: the worker evaluates back to back once the first window is due
    deadline = time.monotonic() + 60.0
    busy = 0.0
    while time.monotonic() < deadline and busy < 0.7:
        assert mon.popen.poll() is None, mon.output()  # the monitor runs
        c0 = _cpu_seconds(mon.popen.pid)
        time.sleep(0.5)
        busy = (_cpu_seconds(mon.popen.pid) - c0) / 0.5
    assert busy >= 0.7, (busy, mon.output())
    time.sleep(delay)
    rc = _sigint_twice(mon)
    assert rc == 0, mon.output()
    _assert_clean(mon.output())


def test_tribo_run_refuses_a_bad_parameter_file_value_in_one_line(tmp_path: Path) -> None:
    """A value of the wrong type in a parameter file stops the graph runner with one line
    naming the node and the parameter (exit 2), not a traceback."""
    from support import tribo_cmd

    params = tmp_path / 'bad.yaml'
    params.write_text('/**/friction_estimator:\n  ros__parameters:\n    block_length: fast\n')
    r = subprocess.run(
        tribo_cmd('run', '--nodes', 'friction_estimator', '--params', str(params),
                  '--duration', '1'),
        capture_output=True, text=True, timeout=120, env={**os.environ, 'TRIBO_ROOT': str(ROOT)},
    )  # fmt: skip
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if 'error' in ln.lower()]
    assert 'Traceback' not in r.stderr and len(lines) == 1, r.stderr
    assert 'friction_estimator' in lines[0] and "'block_length'" in lines[0], r.stderr
