"""Property-based bad-input suite of the analysis commands (hypothesis).

Each command runs in-process (``tribo_bringup.cli.main``) on generated bad input:
rig records with spikes, bursts, unit scalings, time-base changes (ms, epoch,
jitter), cuts, dropped rows, NaN/inf and garbage bytes; bad option values; NVCT
configurations and counts files with bad values. Every run must

* end within a time limit (SIGALRM; pytest-timeout is the backstop),
* exit 0 only with finite, physically bounded results (mu in [0, 2], I1/C1 > 0, ...),
* exit 2 with exactly one error line otherwise (never a traceback, exit 1),
* leave nothing new in ``--out`` when it fails.

Profiles (root conftest.py): ``ci`` (default, a few examples per command, part of
``make test``) and ``fuzz`` (``make fuzz``: 10,000 examples per command).
"""

from __future__ import annotations

import contextlib
import csv
import functools
import io
import json
import math
import os
import signal
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from types import FrameType

import numpy as np
import pytest
from hypothesis import event, given
from hypothesis import strategies as st
from support import ROOT

RIG = ROOT / 'config' / 'rig.yaml'
NVCT = ROOT / 'config' / 'nvct.yaml'
#: Wall-clock limit of one command run [s] (small records: a clean run takes < 5 s;
#: a hard one up to 20 s on a loaded machine; FUZZ_LIMIT_S overrides).
LIMIT_S = float(os.environ.get('FUZZ_LIMIT_S', '120'))
FS = 2000.0
DURATION = 2.2


class _Timeout(Exception):
    """Raised by the alarm inside the command: the CLI answers it as a bug (exit 1,
    traceback), so hypothesis reports and shrinks the input that took too long."""


@contextlib.contextmanager
def _time_limit(seconds: float) -> Iterator[None]:
    def fire(_signum: int, _frame: FrameType | None) -> None:
        raise _Timeout(f'command did not end within {seconds} s')

    old = signal.signal(signal.SIGALRM, fire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, old)


@dataclass
class Run:
    rc: int
    stdout: str
    stderr: str


#: Optional log of every command run (``FUZZ_LOG=path``): one line ``command exit
#: seconds`` each, appended as the run ends, so a long fuzz run that is stopped early
#: still tells how many inputs each command got.
FUZZ_LOG = os.environ.get('FUZZ_LOG', '')
#: The generated input of the running example (for :data:`FUZZ_LOG`).
_CURRENT: dict[str, str] = {}


def tribo(*args: str) -> Run:
    """``tribo ARGS`` in-process within :data:`LIMIT_S`."""
    from tribo_bringup.cli import main

    out, err = io.StringIO(), io.StringIO()
    t0 = time.monotonic()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            with _time_limit(LIMIT_S):
                rc = main(list(args))
        except SystemExit as exc:  # argparse
            rc = int(exc.code or 0)
    if FUZZ_LOG:
        elapsed = time.monotonic() - t0
        with open(FUZZ_LOG, 'a', encoding='utf-8') as fh:
            fh.write(f'{args[0] if args else "-"} {rc} {elapsed:.3f}\n')
            if rc not in (0, 2) or elapsed > 10.0:  # a bug or a slow run: its input
                fh.write(f'# input: {_CURRENT.get("input", "?")}\n')
    if rc == 130 and os.environ.get('HYPOTHESIS_PROFILE') == 'fuzz':
        raise KeyboardInterrupt  # Ctrl-C of a long fuzz run (the command answered it): stop
    msg = err.getvalue().strip().splitlines()[-1:] if rc else []
    kind = msg[0].split(': error: ')[-1].split(':')[-1][:40] if msg else ''
    with contextlib.suppress(Exception):  # outside @given: no statistics
        event(f'exit {rc} {kind}')
    return Run(rc, out.getvalue(), err.getvalue())


def check_failure(r: Run, cmd: str, out: Path) -> None:
    """Exit 2: exactly one error line (the last), no traceback; nothing left in ``out``."""
    assert r.rc in (0, 2), f'exit {r.rc} (1 = a bug):\n{r.stderr}'
    if r.rc != 2:
        return
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    errors = [ln for ln in lines if ': error: ' in ln]
    assert len(errors) == 1, r.stderr
    assert lines[-1] == errors[0] and lines[-1].startswith(f'tribo {cmd}: error: '), r.stderr
    assert 'Traceback' not in r.stderr, r.stderr
    assert not out.exists() or not any(out.iterdir()), sorted(out.iterdir())
    leftovers = [p.name for p in out.parent.iterdir() if '.partial-' in p.name]
    assert not leftovers, leftovers


# ----------------------------------------------------------------------------- records
@functools.cache
def base_record() -> tuple[np.ndarray, ...]:
    """A clean 2.2 s record at 2 kHz of the shipped rig (simulated once)."""
    from tribo_estimation.core.config import load_rig_config
    from tribo_estimation.core.simulate import simulate

    cfg = load_rig_config(RIG)
    r = simulate(
        cfg.rig,
        cfg.friction,
        cfg.drive,
        DURATION,
        FS,
        noise=cfg.noise,
        seed=np.random.default_rng(1),
    )
    return r.time, r.torsion_moment, r.angular_acceleration, r.speed


@functools.cache
def base_decay() -> tuple[np.ndarray, ...]:
    from tribo_estimation.core.config import load_rig_config
    from tribo_estimation.core.model import DriveProfile, FrictionLaw, RigParams
    from tribo_estimation.core.simulate import free_decay_state, simulate

    cfg = load_rig_config(ROOT / 'config' / 'rig_decay_example.yaml')
    rig = RigParams(**{**cfg.rig.__dict__, 'F_N': 0.0})
    r = simulate(
        rig,
        FrictionLaw(0.0, 0.0),
        DriveProfile(0.0),
        1.0,
        FS,
        initial=free_decay_state(0.01),
        noise=cfg.noise,
        seed=np.random.default_rng(2),
    )
    return r.time, r.torsion_moment, r.angular_acceleration, r.speed


CHANNELS = (1, 2, 3)  # torsion_moment, angular_acceleration, speed (0 = time)
BIG = st.sampled_from([1e3, -1e5, 1e8, 1e12, -1e12, 1e100, 1e308, -1e308])

mutation = st.one_of(
    st.tuples(st.just('spike'), st.sampled_from(CHANNELS), st.floats(0, 1), BIG),
    st.tuples(
        st.just('burst'), st.sampled_from(CHANNELS), st.floats(0, 1), st.integers(2, 400), BIG
    ),
    st.tuples(
        st.just('scale'),
        st.sampled_from(CHANNELS),
        st.sampled_from([1e-3, 0.1, 2.0, 30 / math.pi, 57.3, 1e3, 1e6, -1.0, 0.0]),
    ),
    st.tuples(st.just('time_scale'), st.sampled_from([1e-6, 1e-3, 0.5, 2.0, 1e3, 1e6])),
    st.tuples(st.just('epoch'), st.sampled_from([1.7e9, 1.79546274e9, -5.0, 1e12])),
    st.tuples(st.just('jitter'), st.sampled_from([0.01, 0.05, 0.2, 0.45, 2.0]), st.integers(0, 9)),
    st.tuples(st.just('cut'), st.floats(0, 1)),
    st.tuples(st.just('drop'), st.floats(0, 1), st.integers(1, 3000)),
    st.tuples(st.just('swap_time'), st.floats(0, 1)),
    st.tuples(
        st.just('nonfinite'),
        st.sampled_from((0, *CHANNELS)),
        st.floats(0, 1),
        st.sampled_from([math.nan, math.inf, -math.inf]),
    ),
    st.tuples(st.just('constant'), st.sampled_from(CHANNELS), st.sampled_from([0.0, 1e-300])),
)
byte_mutation = st.one_of(
    st.tuples(st.just('garbage'), st.floats(0, 1), st.binary(min_size=1, max_size=64)),
    st.tuples(st.just('truncate'), st.floats(0, 1)),
    st.tuples(st.just('header'), st.sampled_from([b'', b'time,speed\n', b'\xff\xfe\x00'])),
)


def mutate(cols: tuple[np.ndarray, ...], ops: list[tuple]) -> list[np.ndarray]:
    """Apply record mutations (see :data:`mutation`) to copies of the columns."""
    c = [np.array(x, dtype=np.float64) for x in cols]
    for op in ops:
        n = c[0].shape[0]
        if n == 0:
            break
        kind = op[0]
        if kind == 'spike':
            c[op[1]][min(n - 1, int(op[2] * n))] = op[3]
        elif kind == 'burst':
            i = min(n - 1, int(op[2] * n))
            c[op[1]][i : i + op[3]] = op[4]
        elif kind == 'scale':
            c[op[1]] = c[op[1]] * op[2]
        elif kind == 'time_scale':
            c[0] = c[0] * op[1]
        elif kind == 'epoch':
            c[0] = c[0] + op[1]
        elif kind == 'jitter':
            dt = float(np.median(np.diff(c[0]))) if n > 1 else 1.0
            rng = np.random.default_rng(op[2])
            c[0] = c[0] + rng.uniform(-op[1], op[1], n) * dt
        elif kind == 'cut':
            c = [x[: int(op[1] * n)] for x in c]
        elif kind == 'drop':
            i = int(op[1] * n)
            c = [np.delete(x, slice(i, i + op[2])) for x in c]
        elif kind == 'swap_time' and n > 2:
            i = min(n - 2, int(op[1] * n))
            c[0][i], c[0][i + 1] = c[0][i + 1], c[0][i]
        elif kind == 'nonfinite':
            c[op[1]][min(n - 1, int(op[2] * n))] = op[3]
        elif kind == 'constant':
            c[op[1]][:] = op[2]
    return c


def render(cols: list[np.ndarray], bops: list[tuple]) -> bytes:
    """Rig CSV bytes of the columns, then byte-level damage."""
    buf = io.StringIO()
    buf.write('time,torsion_moment,angular_acceleration,speed\n')
    if cols[0].size:
        np.savetxt(buf, np.column_stack(cols), fmt='%.17g', delimiter=',')
    data = buf.getvalue().encode()
    for op in bops:
        if op[0] == 'garbage':
            i = int(op[1] * len(data))
            data = data[:i] + op[2] + data[i + len(op[2]) :]
        elif op[0] == 'truncate':
            data = data[: int(op[1] * len(data))]
        elif op[0] == 'header':
            data = op[1] + data.split(b'\n', 1)[-1]
    return data


@contextlib.contextmanager
def workdir() -> Iterator[Path]:
    with tempfile.TemporaryDirectory(prefix='tribo-fuzz-') as d:
        yield Path(d)


def _floats(path: Path, col: str) -> np.ndarray:
    with path.open() as fh:
        rows = [r for r in csv.DictReader(ln for ln in fh if not ln.startswith('#'))]
    return np.array([float(r[col]) for r in rows], dtype=float)


# ----------------------------------------------------------------------------- friction
@given(ops=st.lists(mutation, min_size=1, max_size=3), bops=st.lists(byte_mutation, max_size=1))
def test_friction_on_bad_records(ops: list[tuple], bops: list[tuple]) -> None:
    _CURRENT['input'] = repr((ops, bops))
    with workdir() as d:
        (d / 'in.csv').write_bytes(render(mutate(base_record(), ops), bops))
        out = d / 'out'
        r = tribo('friction', str(d / 'in.csv'), '--rig', str(RIG), '--out', str(out))
        r_plots = r
        check_failure(r_plots, 'friction', out)
        if r.rc == 0:
            with (out / 'blocks.csv').open() as fh:
                rows = list(csv.DictReader(fh))
            assert rows
            for row in rows:
                for key in ('mu0', 'mu_inf', 't_start', 't_end', 'moment_mean'):
                    assert not math.isinf(float(row[key])), row
                if row['quality'] == 'ok':
                    for key in ('mu0', 'mu_inf'):
                        mu = float(row[key])
                        assert math.isnan(mu) or 0.0 <= mu <= 2.0, row


# ----------------------------------------------------------------------------- decay
@given(ops=st.lists(mutation, min_size=1, max_size=3), bops=st.lists(byte_mutation, max_size=1))
def test_decay_on_bad_records(ops: list[tuple], bops: list[tuple]) -> None:
    _CURRENT['input'] = repr((ops, bops))
    with workdir() as d:
        (d / 'in.csv').write_bytes(render(mutate(base_decay(), ops), bops))
        out = d / 'out'
        r = tribo('decay', str(d / 'in.csv'), '--out', str(out))
        check_failure(r, 'decay', out)
        if r.rc == 0:
            res = json.loads((out / 'decay.json').read_text())
            for key in ('I1', 'C1'):
                assert math.isfinite(res[key]) and res[key] > 0.0, res
            # identified natural frequency inside the DAQ band (0.1-100 kHz sampling)
            assert 0.0 < res['f_n_hz'] < 50_000.0, res


# ----------------------------------------------------------------------------- discrepancy
@given(ops=st.lists(mutation, min_size=1, max_size=2), bops=st.lists(byte_mutation, max_size=1))
def test_discrepancy_on_bad_records(ops: list[tuple], bops: list[tuple]) -> None:
    _CURRENT['input'] = repr((ops, bops))
    with workdir() as d:
        (d / 'in.csv').write_bytes(render(mutate(base_record(), ops), bops))
        out = d / 'out'
        r = tribo(
            'discrepancy',
            str(d / 'in.csv'),
            '--rig',
            str(RIG),
            '--out',
            str(out),
            '--no-plots',
            '--candidates',
            'torque_offset,viscous_friction',
            '--max-effects',
            '1',
        )
        check_failure(r, 'discrepancy', out)
        if r.rc == 0:
            res = json.loads((out / 'discrepancy.json').read_text())
            text = json.dumps(res)
            assert 'Infinity' not in text, text[:400]


# ----------------------------------------------------------------------------- simulate
bad_number = st.one_of(
    st.sampled_from(['nan', 'inf', '-inf', '1e308', '-1', '0', '1e-300', 'abc', '', '1e5']),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
)


@given(
    duration=bad_number,
    fs=st.one_of(st.none(), bad_number),
    speed=st.one_of(st.none(), bad_number),
    phi0=st.one_of(st.none(), bad_number),
    free=st.booleans(),
)
def test_simulate_on_bad_options(
    duration: str, fs: str | None, speed: str | None, phi0: str | None, free: bool
) -> None:
    with workdir() as d:
        out = d / 'out' / 'rig.csv'
        args = ['simulate', '--rig', str(RIG), '--duration', duration, '--out', str(out)]
        if fs is not None:
            args += ['--fs', fs]
        if speed is not None:
            args += ['--speed', speed]
        if phi0 is not None:
            args += ['--phi0', phi0]
        if free:
            args.append('--free-decay')
        try:
            dur = float(duration)
            rate = float(fs) if fs is not None else 10_000.0
        except ValueError:
            dur, rate = math.nan, math.nan
        if not (dur * rate <= 50_000):  # keep the examples small: a long run is no bad input
            args[args.index('--duration') + 1] = 'nan'
        r = tribo(*args)
        check_failure(r, 'simulate', out.parent)
        if r.rc == 0:
            for col in ('time', 'torsion_moment', 'angular_acceleration', 'speed'):
                assert np.all(np.isfinite(_floats(out, col)))


# ----------------------------------------------------------------------------- wear
NVCT_VALUES = st.one_of(
    st.sampled_from([1e308, -1.0, 0.0, 'abc', None, [1, 2], {'a': 1}, True, '1e5', 1e5, 'nan']),
    st.floats(allow_nan=True, allow_infinity=True),
)
NVCT_KEYS = st.sampled_from(
    [
        'load_N',
        'stroke_m',
        'frequency_hz',
        'k_det',
        'k_det_rel_sd',  # misspelt
        'tagged_area_um2',
        'background_cps',
        'days_since_reference',
        'temperature_K',
        'window_min',
        'circulation_time_s',
        'sliding_distance',
        'nuclide',
        'unknown_key',
    ]
)


@functools.cache
def counts_csv() -> bytes:
    with workdir() as d:
        r = tribo('wear', '--simulate', str(d / 'counts.csv'), '--seed', '3')
        assert r.rc == 0, r.stderr
        return (d / 'counts.csv').read_bytes()


@given(
    changes=st.dictionaries(NVCT_KEYS, NVCT_VALUES, max_size=2),
    bops=st.lists(
        st.one_of(
            st.tuples(st.just('garbage'), st.floats(0, 1), st.binary(min_size=1, max_size=16)),
            st.tuples(st.just('truncate'), st.floats(0, 1)),
        ),
        max_size=1,
    ),
)
def test_wear_on_bad_configs_and_counts(changes: dict[str, object], bops: list[tuple]) -> None:
    import yaml

    raw = yaml.safe_load(NVCT.read_text())
    raw['depth_profile'] = str(ROOT / 'config' / 'depth_profile.csv')
    raw.update(changes)
    with workdir() as d:
        (d / 'nvct.yaml').write_text(yaml.safe_dump(raw))
        data = counts_csv()
        for op in bops:
            if op[0] == 'garbage':
                i = int(op[1] * len(data))
                data = data[:i] + op[2] + data[i + len(op[2]) :]
            else:
                data = data[: int(op[1] * len(data))]
        (d / 'counts.csv').write_bytes(data)
        out = d / 'out'
        r = tribo(
            'wear', str(d / 'counts.csv'), '--nvct', str(d / 'nvct.yaml'), '--out', str(out),
            '--no-plots',
        )  # fmt: skip
        check_failure(r, 'wear', out)
        if r.rc == 0:
            s = json.loads((out / 'summary.json').read_text())
            assert 0.0 < s['load_N'] <= 1e6, s
            v = s.get('total_volume_um3')
            assert v is None or (math.isfinite(v) and abs(v) < 1e12), s


# ----------------------------------------------------------------------------- the fixes
@pytest.mark.parametrize(
    'args',
    [
        ('replay', 'x', '--rate', '1e-300'),
        ('friction', 'x', '--rig', 'y', '--out', 'z', '--block', 'inf'),
        ('discrepancy', 'x', '--rig', 'y', '--out', 'z', '--start', 'nan'),
        ('decay', 'x', '--out', 'z', '--t-end', '-1e308'),
        ('wear', '--simulate', 'x.csv', '--seed', '-1'),
    ],
)
def test_bad_option_values_are_one_line(args: tuple[str, ...]) -> None:
    with workdir() as d:
        r = tribo(*args)
        assert r.rc == 2
        check_failure(r, args[0], d / 'nothing')
