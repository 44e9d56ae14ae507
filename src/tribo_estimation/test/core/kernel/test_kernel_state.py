"""The kernel's state is defined in one place: the state table of ``kernel/layout.py``.

- every index, size and ``RigState`` conversion follows the table;
- the integrator modules address the integrated state ``y`` only through ``Y_*``
  names (no literal indices, no hand-written tuple of its length, no ``y0..y4``);
- the proof: a copy of the package with one extra integrated state (its table entry
  and name, its rate in ``effect_rates``, its typed ``RigState`` field -- nothing
  else) simulates the old channels bit for bit and integrates the new state right.
"""

from __future__ import annotations

import ast
import dataclasses
import json
import math
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tribo_estimation.core import kernel as kn
from tribo_estimation.core.kernel import layout
from tribo_estimation.core.model import RigState
from tribo_estimation.errors import InvalidParameterError

KERNEL_DIR = Path(kn.__file__).resolve().parent
PACKAGE_DIR = KERNEL_DIR.parents[1]
#: Modules that carry the integrated state (everything in kernel/ but the table).
CARRIERS = ('equations.py', 'events.py', 'integrate.py', 'state.py', 'step.py')


# ------------------------------------------------------------------ the table
def test_state_indices_and_sizes_derive_from_the_table() -> None:
    names = [slot.name for slot in kn.STATE_SLOTS]
    assert len(set(names)) == len(names)
    assert len(kn.STATE_SLOTS) == kn.NS
    s_consts = {k: v for k, v in vars(layout).items() if re.fullmatch(r'S_[A-Z0-9]+', k)}
    s_consts.pop('S_FINITE')
    # every S_* constant names a distinct slot, and every slot has one
    assert sorted(s_consts.values()) == list(range(kn.NS))
    assert tuple(i for i, sl in enumerate(kn.STATE_SLOTS) if sl.finite) == kn.S_FINITE
    # y: the integrated slots in table order; every Y_* maps to one integrated S_*
    assert tuple(i for i, sl in enumerate(kn.STATE_SLOTS) if sl.integrated) == kn.Y_SLOTS
    assert len(kn.Y_SLOTS) == kn.NY
    y_consts = {k: v for k, v in vars(layout).items() if re.fullmatch(r'Y_[A-Z0-9]+', k)}
    y_consts.pop('Y_SLOTS')
    y_consts.pop('Y_ZERO')
    assert sorted(y_consts.values()) == list(range(kn.NY))
    for name, j in y_consts.items():
        assert s_consts['S_' + name[2:]] == kn.Y_SLOTS[j]
        assert kn.y_index(kn.STATE_SLOTS[kn.Y_SLOTS[j]].name) == j
    assert (kn.D_M, kn.ND) == (kn.NY, kn.NY + 1)
    assert kn.Y_ZERO == (0.0,) * kn.NY
    assert kn.D_ZERO == (0.0,) * kn.ND


def test_slot_lookup_names_an_unknown_or_non_integrated_slot() -> None:
    with pytest.raises(InvalidParameterError, match="no slot 'nope'"):
        kn.state_index('nope')
    with pytest.raises(InvalidParameterError, match="'stuck' is not integrated"):
        kn.y_index('stuck')


def test_rigstate_has_one_field_per_slot_and_round_trips() -> None:
    fields = {f.name: f for f in dataclasses.fields(RigState)}
    assert set(fields) == {slot.name for slot in kn.STATE_SLOTS}
    # distinct values per slot: each field lands in its own slot and comes back
    values: dict[str, float | bool | int] = {}
    for i, slot in enumerate(kn.STATE_SLOTS):
        values[slot.name] = {'flag': i % 2 == 0, 'sign': -1}.get(slot.kind, 0.5 + i)
    st = RigState(**values)
    s = st.to_vector()
    assert s.shape == (kn.NS,)
    for i, slot in enumerate(kn.STATE_SLOTS):
        assert s[i] == float(values[slot.name]), slot.name
    back = RigState.from_vector(s)
    assert back == st
    for slot in kn.STATE_SLOTS:
        expected = {'flag': bool, 'sign': int, 'value': float}[slot.kind]
        assert type(getattr(back, slot.name)) is expected, slot.name


@pytest.mark.parametrize('slot', kn.STATE_SLOTS, ids=lambda sl: sl.name)
def test_rigstate_checks_each_slot_as_the_table_says(slot: kn.StateSlot) -> None:
    if slot.kind == 'flag':
        return
    if slot.kind == 'sign':
        with pytest.raises(InvalidParameterError, match=f'RigState.{slot.name} must be'):
            RigState(**{slot.name: 0})
        return
    if slot.finite:
        with pytest.raises(InvalidParameterError, match=f'RigState.{slot.name} must be finite'):
            RigState(**{slot.name: math.nan})
    else:
        assert math.isnan(getattr(RigState(**{slot.name: math.nan}), slot.name))


# ------------------------------------------------------------------ the tuple builders
def test_tuple_builders_follow_the_state_length() -> None:
    from tribo_estimation.core.kernel import state

    rng = np.random.default_rng(7)
    s = rng.normal(size=kn.NS)
    y = state.from_state(s)
    assert y == tuple(s[i] for i in kn.Y_SLOTS)
    s2 = np.full(kn.NS, np.nan)
    state.to_state(y, s2)
    np.testing.assert_array_equal(s2[list(kn.Y_SLOTS)], s[list(kn.Y_SLOTS)])
    assert np.isnan(np.delete(s2, list(kn.Y_SLOTS))).all()  # other slots untouched
    k = [tuple(rng.normal(size=kn.ND)) for _ in range(4)]
    a = 1e-3
    # entries past NY (the friction moment) are ignored; 1-ulp tolerance for rounding
    np.testing.assert_allclose(
        state.axpy(y, a, k[0]), np.array(y) + a * np.array(k[0][: kn.NY]), rtol=4e-16
    )
    ref = np.array(y) + (2.0 * (np.array(k[1]) + np.array(k[2])) + np.array(k[0]) + np.array(k[3]))[
        : kn.NY
    ] * (a / 6.0)
    np.testing.assert_allclose(state.rk4_combine(y, a / 6.0, *k), ref, rtol=4e-16)
    # with_entry called from Python runs its Python body (the compiled form is used above)
    assert state.with_entry(y, kn.Y_W2, 5.0) == (*y[: kn.Y_W2], 5.0, *y[kn.Y_W2 + 1 :])
    assert state.with_entry(kn.D_ZERO, kn.D_M, 2.0)[kn.D_M] == 2.0


# ------------------------------------------------------------------ no fixed length
def _violations(path: Path) -> list[str]:
    """Literal indices into names, tuple displays of y's length, y0..y9 parameters."""
    tree = ast.parse(path.read_text(encoding='utf-8'))
    # parallel assignments (a, b, c = x, y, z) build no state tuple
    parallel = {
        id(side)
        for node in ast.walk(tree)
        if isinstance(node, ast.Assign) and isinstance(node.targets[0], ast.Tuple)
        for side in (node.targets[0], node.value)
    }
    found = []
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Subscript)
            and isinstance(node.value, ast.Name)
            and isinstance(node.slice, ast.Constant | ast.UnaryOp)
        ):
            found.append(f'{path.name}:{node.lineno}: {ast.unparse(node)}')
        if isinstance(node, ast.Tuple) and len(node.elts) >= kn.NY and id(node) not in parallel:
            found.append(f'{path.name}:{node.lineno}: tuple of {len(node.elts)}')
        if isinstance(node, ast.FunctionDef):
            for arg in node.args.args:
                if re.fullmatch(r'y\d', arg.arg):
                    found.append(f'{path.name}:{node.lineno}: parameter {arg.arg}')
    return found


def test_integrator_modules_address_y_only_by_name() -> None:
    found = [v for name in CARRIERS for v in _violations(KERNEL_DIR / name)]
    assert found == []


def test_the_scan_finds_the_old_fixed_length_code(tmp_path: Path) -> None:
    old = tmp_path / 'old.py'
    old.write_text(
        'def f(p, t, y0, y1, y2, y3, y4, k1):\n'
        '    y = (y0, k1[1], y2, k1[1], y4)\n'
        '    return y[3] - y[1]\n',
        encoding='utf-8',
    )
    found = _violations(old)
    assert len(found) == 5 + 1 + 2 + 2, found  # 5 parameters, 1 tuple, 4 indices


# ------------------------------------------------------------------ the proof
_ADDED_SLOT = "    StateSlot('probe', 'rad', 'value', True, True, 'test probe: integral of w1'),\n"

_RUN = """
import json, math, sys
sys.path.insert(0, sys.argv[1])
import tribo_estimation
from tribo_estimation.core import kernel as kn
from tribo_estimation.core.model import DriveProfile, Extensions, FrictionLaw, RigParams
from tribo_estimation.core.simulate import simulate
rig, law = RigParams.tab1(), FrictionLaw(0.13, 0.10)
drive = DriveProfile(10 * math.pi / 30)
ext = Extensions(stiction_gain=0.02, stiction_tau=0.05, lag_tau=0.004, torque_lag_tau=0.001)
one = simulate(rig, law, drive, 0.07, extensions=ext)
first = simulate(rig, law, drive, 0.035, extensions=ext)
second = simulate(rig, law, drive, 0.035, extensions=ext, initial=first.final_state)
chans = ('torsion_moment', 'angular_acceleration', 'speed', 'friction_moment', 'chamber_speed')
def fields(st):
    return {f: float(getattr(st, f)) for f in st.__dataclass_fields__}
print(json.dumps({
    'package': tribo_estimation.__file__,
    'NY': kn.NY,
    'channels': {c: getattr(one, c).tolist() for c in chans},
    'continued': second.torsion_moment.tolist(),
    'events': one.event_kinds.tolist(),
    'final': fields(one.final_state),
    'final2': fields(second.final_state),
}))
"""


def _edit(path: Path, anchor: str, insert: str, *, before: bool = False) -> None:
    text = path.read_text(encoding='utf-8')
    assert text.count(anchor) == 1, f'{path.name}: anchor {anchor!r} not found once'
    new = insert + anchor if before else anchor + insert
    path.write_text(text.replace(anchor, new), encoding='utf-8')


def _run(root: Path) -> dict[str, object]:
    env = dict(os.environ, NUMBA_DISABLE_JIT='1')  # plain Python: no compile in a test
    proc = subprocess.run(
        [sys.executable, '-c', _RUN, str(root)],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    out: dict[str, object] = json.loads(proc.stdout)
    assert Path(str(out['package'])).resolve().is_relative_to(root.resolve())
    return out


def test_an_extra_integrated_state_needs_only_its_entry_rate_and_field(tmp_path: Path) -> None:
    """Add state ``probe`` with ``probe' = w1``: the table entry and its ``Y_`` name
    (layout.py), its rate in ``effect_rates`` (equations.py) and its ``RigState`` field
    (model.py). Then the old channels are bit-identical and ``probe`` equals ``phi1``
    (both start at 0 and integrate ``w1`` with the same RK4 arithmetic), also after a
    continuation through ``RigState``."""
    base_root = tmp_path / 'base'
    new_root = tmp_path / 'new'
    for root in (base_root, new_root):
        shutil.copytree(
            PACKAGE_DIR, root / 'tribo_estimation', ignore=shutil.ignore_patterns('__pycache__')
        )
    kern = new_root / 'tribo_estimation' / 'core' / 'kernel'
    lag_entry = next(
        line + '\n'
        for line in (kern / 'layout.py').read_text(encoding='utf-8').splitlines()
        if line.startswith("    StateSlot('lag',")
    )
    _edit(kern / 'layout.py', lag_entry, _ADDED_SLOT)
    _edit(kern / 'layout.py', "Y_LAG = y_index('lag')", "\nY_PROBE = y_index('probe')")
    _edit(
        kern / 'equations.py',
        '    if stuck:\n        return d\n',
        '    d = with_entry(d, Y_PROBE, y[Y_W1])\n',
        before=True,
    )
    _edit(kern / 'equations.py', '    Y_LAG,\n', '    Y_PROBE,\n')
    _edit(
        new_root / 'tribo_estimation' / 'core' / 'model.py',
        '    sensor_lag: float = math.nan\n',
        '    probe: float = 0.0\n',
    )

    base = _run(base_root)
    new = _run(new_root)
    assert (base['NY'], new['NY']) == (kn.NY, kn.NY + 1)
    assert base['events'] == new['events']
    assert len(base['events']) >= 3  # type: ignore[arg-type]  # breakaway, peak, slip end
    assert base['channels'] == new['channels']  # bit for bit
    assert base['continued'] == new['continued']
    fin = new['final']
    assert isinstance(fin, dict)
    assert fin['probe'] == fin['phi1'] != 0.0
    fin2 = new['final2']
    assert isinstance(fin2, dict)
    # the second chunk started from RigState(probe = phi1): still equal at its end
    assert fin2['probe'] == pytest.approx(fin2['phi1'], rel=1e-12, abs=0.0)
    base_fin = base['final']
    assert isinstance(base_fin, dict)
    assert {k: v for k, v in fin.items() if k != 'probe'} == pytest.approx(base_fin, nan_ok=True)
    np.testing.assert_array_equal(np.asarray(new['continued']), np.asarray(base['continued']))
