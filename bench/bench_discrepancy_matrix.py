"""Confusion matrix of the missing-physics workflow on independent records.

Records come from the independent reference simulator (core/reference_records.py:
its own equations, instrument model with the noise of config/rig.yaml) with one
effect hidden: every candidate of core/discrepancy/effects/ in turn at two
magnitudes (the realistic values of config/rig_hidden_<effect>.yaml and 0.4x),
the no-effect control and two effects outside the library (core/reference.py
``Unmodelled``: a drive backlash, a dead band in the belt deflection of Equ. 2; a
measuring-spring stiffness C1 that grows by 2 % during the record). Conditions:
constant 10 / 25 / 60 rpm (mid-test), a speed step 15 -> 35 rpm, the start-up in
the record, a 5 ms speed-sensor lag, noise x3. Each record is analysed with
``run_discrepancy`` (max one effect) and the plain config/rig.yaml.

Rows: hidden effect; columns: the first named effect / "not identifiable" (the
effect that explains most is one the record cannot separate) / nothing / unexplained
(nothing named, residual structure described). Printed: the matrix, the wall
times, the percent correct among cases the workflow calls identifiable (its own
verdict on the hidden effect), residual after adding vs the noise floor, parameter
errors, and the worst cases. A joint row: viscous friction hidden in a 10 and a 60 rpm
record that neither decides alone, then the joint fit of both (one friction law).

    .venv/bin/python bench/bench_discrepancy_matrix.py [--quick | --full] [--duration 3]

``make bench`` runs the quick set (the default).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
from collections import Counter, defaultdict
from pathlib import Path
from typing import TypedDict

import validation_doc

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / 'src' / 'tribo_estimation'))

from tribo_estimation.core.config import load_rig_config  # noqa: E402
from tribo_estimation.core.discrepancy import candidates as cand_lib  # noqa: E402
from tribo_estimation.core.discrepancy.fitting import Record  # noqa: E402
from tribo_estimation.core.discrepancy.joint import run_joint_discrepancy  # noqa: E402
from tribo_estimation.core.discrepancy.select import (  # noqa: E402
    SelectionSettings,
    run_discrepancy,
)
from tribo_estimation.core.model import DriveProfile, Extensions  # noqa: E402
from tribo_estimation.core.reference import SpeedProfile, Unmodelled  # noqa: E402
from tribo_estimation.core.reference_records import (  # noqa: E402
    RecordSpec,
    make_record,
    rig_channels,
    rpm,
)

CONFIG = ROOT / 'config'
CFG = load_rig_config(CONFIG / 'rig.yaml')
FLOOR = 0.05  # torsion-moment noise of config/rig.yaml [N m]
#: Fields that are shapes, not magnitudes (kept when the magnitude is scaled).
SHAPE_FIELDS = {'stiction_tau', 'ripple_freq', 'ripple_phase', 'bearing_reg_speed'}
LOW = 0.4
CONTROL, BACKLASH, C1_DRIFT = 'control', 'backlash*', 'C1_drift*'
OUTSIDE = (BACKLASH, C1_DRIFT)


def hidden(name: str, scale: float) -> dict[str, float]:
    """Return the hidden effect's Extensions fields, magnitudes times ``scale``.

    The non-default fields of config/rig_hidden_<name>.yaml, else the candidate's
    registered demo values.
    """
    path = CONFIG / f'rig_hidden_{name}.yaml'
    demo = cand_lib.get(name).demo_effects
    if not path.is_file() and demo is not None:
        return {k: v if k in SHAPE_FIELDS else v * scale for k, v in demo.items()}
    e = load_rig_config(path).extensions
    d = Extensions()
    out = {}
    for f in dataclasses.fields(e):
        v = getattr(e, f.name)
        if v != getattr(d, f.name):
            out[f.name] = v if f.name in SHAPE_FIELDS else v * scale
    return out


def condition(name: str, duration: float) -> tuple[SpeedProfile, float, float, float, float]:
    """(drive profile, start offset [s], nominal speed [rad/s], speed lag [s], noise x)."""
    w25 = rpm(25)
    if name in ('10rpm', '25rpm', '60rpm'):
        w = rpm(float(name[:-3]))
        return SpeedProfile.startup(w, 0.2), 0.5, w, 0.0, 1.0
    if name == 'step':
        prof = SpeedProfile.steps([rpm(15), rpm(35)], [0.5 + duration / 2])
        return prof, 0.5, rpm(15), 0.0, 1.0
    if name == 'startup':
        return SpeedProfile.startup(w25, 0.2), 0.0, w25, 0.0, 1.0
    if name == 'lag5ms':
        return SpeedProfile.startup(w25, 0.2), 0.5, w25, 0.005, 1.0
    if name == 'noise3':
        return SpeedProfile.startup(w25, 0.2), 0.5, w25, 0.0, 3.0
    raise ValueError(name)


def cases(quick: bool) -> list[tuple[str, float, str]]:
    """Return the (hidden, magnitude scale, condition) cases to run.

    ``quick``: both magnitudes at
    25 rpm, the realistic one with the speed step and noise x3; controls at 25 rpm,
    the step, 60 rpm (and the control at 10 rpm and with the 5 ms lag).
    """
    conds = ['25rpm', 'step', '10rpm', '60rpm', 'startup', 'lag5ms', 'noise3']
    out = []
    for c in cand_lib.names():
        if quick:
            out += [(c, 1.0, '25rpm'), (c, LOW, '25rpm'), (c, 1.0, 'step'), (c, 1.0, 'noise3')]
        else:
            out += [(c, m, cond) for cond in conds for m in (1.0, LOW)]
    for h in (CONTROL, *OUTSIDE):
        for cond in conds:
            if not quick or cond in ('25rpm', 'step', '60rpm'):
                out.append((h, 1.0, cond))
    if quick:
        out += [(CONTROL, 1.0, '10rpm'), (CONTROL, 1.0, 'lag5ms')]
    return out


class CaseRow(TypedDict):
    """One row of the matrix: hidden effect, magnitude, condition and the workflow's answer.

    ``rms0``/``rms1``/``floor``: baseline, final rms and noise floor [N m]; ``perr``:
    worst relative parameter error [-]; ``wall``: workflow time [s]; ``block_loss``: the
    named effect's worst relative cost increase in a time block [-].
    """

    hidden: str
    scale: float
    cond: str
    outcome: str
    ident: bool | None
    reason: str
    suggest: str
    rms0: float
    rms1: float
    floor: float
    perr: float
    wall: float
    unexplained: str
    blocked: str
    inconsistent: str
    block_loss: float


class JointRow(TypedDict):
    """The joint row: per record (identifiable, fitted viscous [N m s/rad], named), then joint."""

    singles: list[tuple[bool, float, bool]]
    named: str
    ident: bool
    reason: str
    perr: float
    fit: float
    wall_single: float
    wall_joint: float


def run_case(h: str, scale: float, cond: str, duration: float, seed: int) -> CaseRow:
    """Generate one record with effect ``h`` hidden and run the workflow on it; one table row."""
    prof, start, w_nom, lag, noise = condition(cond, duration)
    tc, ac, sc = rig_channels(noise, speed_lag=lag)
    ext = Extensions(**hidden(h, scale)) if h not in (CONTROL, *OUTSIDE) else Extensions()
    un = Unmodelled()
    if h == BACKLASH:
        un = Unmodelled(backlash=0.01)  # rad, full width (the static deflection ~0.014 rad)
    elif h == C1_DRIFT:
        un = Unmodelled(stiffness_drift=0.02 / (start + duration))  # +2 % by the record end
    spec = RecordSpec(CFG.rig, CFG.friction, prof, extensions=ext, unmodelled=un,
                      torsion=tc, accel=ac, speed=sc, seed=seed, duration=duration,
                      start_offset=start)  # fmt: skip
    r = make_record(spec)
    rec = Record(r.time - r.time[0], r.torsion_moment, r.angular_acceleration, r.speed)
    t0 = time.perf_counter()
    res = run_discrepancy(rec, CFG.rig, DriveProfile(w_nom, 0.2 if start == 0 else 0.0),
                          k=CFG.friction.k, settings=SelectionSettings(max_effects=1))  # fmt: skip
    wall = time.perf_counter() - t0
    if res.added:
        outcome = res.added[0].effect
    elif res.blocked:
        outcome = 'not identifiable'
    elif res.unexplained:
        outcome = 'unexplained'
    else:
        outcome = 'nothing'
    verdict = res.identifiable.get(h)
    named = [s for s in res.rounds[0] if s.effect == res.added[0].effect] if res.added else []
    loss = named[0].block_loss if named else math.nan
    perr = math.nan
    if res.added and res.added[0].effect == h:
        truth = hidden(h, scale)
        errs = [
            abs(res.added[0].params[n] / truth[n] - 1.0)
            for n in cand_lib.get(h).param_names
            if truth.get(n, 0.0) != 0.0 and n != 'ripple_phase'
        ]
        perr = max(errs) if errs else math.nan
    return {
        'hidden': h,
        'scale': scale,
        'cond': cond,
        'outcome': outcome,
        'ident': verdict.ok if verdict is not None else None,
        'reason': verdict.reason if verdict is not None else '',
        'suggest': verdict.suggest if verdict is not None else '',
        'rms0': res.baseline.rms,
        'rms1': res.final.rms,
        'floor': FLOOR * noise,
        'perr': perr,
        'wall': wall,
        'unexplained': '; '.join(f'{u.kind} {u.where} {u.size:.3g} N m' for u in res.unexplained),
        'blocked': ','.join(res.blocked),
        'inconsistent': ','.join(res.inconsistent),
        'block_loss': loss,
    }


#: The joint row: viscous friction [N m s/rad] hidden in 1 s records at 10 and 60 rpm of
#: one contact, noise x3 (neither record alone can pin it down: relative SE > 20 %).
JOINT_VISCOUS, JOINT_SPEEDS, JOINT_NOISE, JOINT_DURATION = 0.009, (10.0, 60.0), 3.0, 1.0


def run_joint_case(seed: int) -> JointRow:
    """Each record alone, then the joint fit (one friction law, viscous shared)."""
    tc, ac, sc = rig_channels(JOINT_NOISE)
    recs, drives = [], []
    for s in JOINT_SPEEDS:
        spec = RecordSpec(CFG.rig, CFG.friction, SpeedProfile.startup(rpm(s), 0.2),
                          extensions=Extensions(viscous=JOINT_VISCOUS), torsion=tc, accel=ac,
                          speed=sc, seed=seed + int(s), duration=JOINT_DURATION,
                          start_offset=0.5)  # fmt: skip
        r = make_record(spec)
        recs.append(Record(r.time - r.time[0], r.torsion_moment, r.angular_acceleration, r.speed))
        drives.append(DriveProfile(rpm(s), 0.0))
    st = SelectionSettings(candidates=('viscous_friction',), max_effects=1, min_gain=0.02,
                           propose_terms=False)  # fmt: skip
    t0 = time.perf_counter()
    singles = []
    for rec, drv in zip(recs, drives, strict=True):
        res = run_discrepancy(rec, CFG.rig, drv, k=CFG.friction.k, settings=st)
        v = res.identifiable['viscous_friction']
        singles.append((v.ok, res.rounds[0][0].model.params['viscous'], bool(res.added)))
    t1 = time.perf_counter()
    jr = run_joint_discrepancy(recs, CFG.rig, drives, k=CFG.friction.k, settings=st,
                               shared_friction=True)  # fmt: skip
    t2 = time.perf_counter()
    v = jr.identifiable['viscous_friction']
    fit = float(jr.scores['viscous_friction']['params']['viscous'])
    return {'singles': singles, 'named': jr.named, 'ident': v.ok, 'reason': v.reason,
            'perr': abs(fit / JOINT_VISCOUS - 1.0), 'fit': fit, 'wall_single': t1 - t0,
            'wall_joint': t2 - t1}  # fmt: skip


def main() -> int:
    """Run the matrix and print it; returns the exit code."""
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument(
        '--quick', action='store_true', help='fewer conditions (47 records, ~6 min; the default)'
    )
    ap.add_argument('--full', action='store_true', help='every condition (133 records, ~20 min)')
    ap.add_argument('--duration', type=float, default=3.0, help='record length [s]')
    ap.add_argument('--only', default='', help='comma-separated hidden effects to run')
    args = ap.parse_args()
    args.quick = not args.full
    # each case keeps its seed (its place in the whole list) when --only picks a few
    todo = [(1000 + i, *c) for i, c in enumerate(cases(args.quick))]
    if args.only:
        keep = set(args.only.split(','))
        todo = [c for c in todo if c[1] in keep]
    rows: list[CaseRow] = []
    t_all = time.perf_counter()
    for seed, h, scale, cond in todo:
        r = run_case(h, scale, cond, args.duration, seed=seed)
        rows.append(r)
        print(
            f'{h:<20s} x{scale:<4g} {cond:<8s} -> {r["outcome"]:<20s} ident={r["ident"]!s:<5s} '
            f'rms {r["rms0"]:.3f} -> {r["rms1"]:.3f} N m ({r["rms1"] / r["floor"]:.2f} floor) '
            f'perr {r["perr"]:.2f} worst block {r["block_loss"]:+.2f} {r["wall"]:.1f} s'
            + (f' (not identifiable: {r["blocked"]})' if r['blocked'] else '')
            + (f' (inconsistent: {r["inconsistent"]})' if r['inconsistent'] else ''),
            flush=True,
        )
    total = time.perf_counter() - t_all
    cols = [*cand_lib.names(), 'not identifiable', 'nothing', 'unexplained']
    short = {c: c[:9] for c in cols}
    hidden_rows = [*cand_lib.names(), CONTROL, *OUTSIDE]
    counts: dict[str, Counter[str]] = defaultdict(Counter)
    for r in rows:
        counts[r['hidden']][r['outcome']] += 1
    print(f'\nConfusion matrix ({len(rows)} records of {args.duration:g} s'
          f'{", --quick" if args.quick else ""}); rows hidden, columns outcome')  # fmt: skip
    print(f'{"hidden":<20s}' + ''.join(f'{short[c]:>10s}' for c in cols))
    for h in hidden_rows:
        if counts[h]:
            print(f'{h:<20s}' + ''.join(f'{counts[h][c] or ".":>10}' for c in cols))
    # the numbers
    cand_rows = [r for r in rows if r['hidden'] in cand_lib.names()]
    ident = [r for r in cand_rows if r['ident']]
    right = [r for r in ident if r['outcome'] == r['hidden']]
    print(
        f"\nidentifiable by the workflow's own verdict: {len(ident)}/{len(cand_rows)}; "
        f'first named = hidden in {len(right)}/{len(ident)}'
        f' ({100 * len(right) / max(len(ident), 1):.0f} %, target >= 95 %)'
    )
    named_right = [r for r in cand_rows if r['outcome'] == r['hidden']]
    print(f'first named = hidden among all effect records: {len(named_right)}/{len(cand_rows)}')
    if named_right:
        ratios = sorted(r['rms1'] / r['floor'] for r in named_right)
        perrs = sorted(r['perr'] for r in named_right if math.isfinite(r['perr']))
        print(
            f'residual after adding / noise floor: median {ratios[len(ratios) // 2]:.2f}, '
            f'worst {ratios[-1]:.2f} (target <= 1.5); parameter error: median '
            f'{100 * perrs[len(perrs) // 2]:.0f} %, worst {100 * perrs[-1]:.0f} % (target 20 %)'
            if perrs
            else ''
        )
    wrong = [
        r for r in cand_rows if r['outcome'] in cand_lib.names() and r['outcome'] != r['hidden']
    ]
    print(f'wrong effect named: {len(wrong)}')
    for r in wrong:
        print(f'  {r["hidden"]} x{r["scale"]:g} {r["cond"]}: named {r["outcome"]}')
    ctrl = [r for r in rows if r['hidden'] in (CONTROL, *OUTSIDE)]
    bad = [r for r in ctrl if r['outcome'] in cand_lib.names()]
    print(f'controls and out-of-library records naming an effect: {len(bad)}/{len(ctrl)} '
          '(target 0)')  # fmt: skip
    for r in bad:
        print(f'  {r["hidden"]} {r["cond"]}: named {r["outcome"]} (rms {r["rms0"]:.3f} N m)')
    for r in ctrl:
        if r['hidden'] in OUTSIDE and r['unexplained']:
            print(f'  {r["hidden"]} {r["cond"]} unexplained: {r["unexplained"][:120]}')
    ni = [r for r in cand_rows if not r['ident']]
    reasons = Counter((r['hidden'], r['suggest']) for r in ni)
    print('not identifiable by verdict (hidden effect, suggestion): ' + ', '.join(
        f'{h} [{s}] x{n}' for (h, s), n in sorted(reasons.items())))  # fmt: skip
    j = run_joint_case(seed=7)
    sing = ', '.join(
        f'{s:g} rpm: {"identifiable" if ok else "not identifiable"} ({fit:.4g})'
        for s, (ok, fit, _named) in zip(JOINT_SPEEDS, j['singles'], strict=True)
    )
    print(
        f'\njoint row: viscous_friction {JOINT_VISCOUS:g} N m s/rad hidden at '
        f'{" + ".join(f"{s:g}" for s in JOINT_SPEEDS)} rpm ({JOINT_DURATION:g} s each, noise '
        f'x{JOINT_NOISE:g}); alone: {sing}; joint (one friction law): '
        f'{j["named"] or "nothing named"}, identifiable={j["ident"]}, fitted {j["fit"]:.4g} '
        f'(error {100 * j["perr"]:.0f} %, target 20 %); {j["reason"]}; wall '
        f'{j["wall_single"]:.1f} s alone, {j["wall_joint"]:.1f} s joint'
    )
    walls = sorted(r['wall'] for r in rows)
    print(
        f'\nwall time per record: median {walls[len(walls) // 2]:.1f} s, worst {walls[-1]:.1f} s; '
        f'total {total:.0f} s (generation included)'
    )
    return 0


if __name__ == '__main__':
    sys.exit(validation_doc.run(__file__, main))
