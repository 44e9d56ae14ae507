"""Confusion matrix of the missing-physics pipeline on independent records (regression).

Records come from the independent reference simulator (core/reference_records.py:
its own equations, instrument model with the noise of config/rig.yaml) with one
effect hidden: every effect family of core/discrepancy/effects/ in turn (its form that
the reference simulator has: the values of config/rig_hidden_<family>.yaml, else the
form's demo values) at two magnitudes (realistic and 0.4x), the no-effect control and
two effects outside the library (core/reference.py ``Unmodelled``: a drive backlash, a
dead band in the belt deflection of Equ. 2; a measuring-spring stiffness C1 that grows
by 2 % during the record). Conditions: constant 10 / 25 / 60 rpm (mid-test), a speed
step 15 -> 35 rpm, the start-up in the record, a 5 ms speed-sensor lag, noise x3. Each
record is analysed by :func:`tribo_estimation.core.discrepancy.find_missing_physics`
(``Policy(max_effects=1)``) with the plain config/rig.yaml.

Rows: hidden family; columns: the verdict: the family named, a set the record cannot
tell apart with / without the hidden family (``in set`` / ``other set``), ``nothing``
(nothing missing), ``unexplained``, ``instrument``. Printed: the matrix, the hidden
family named among the effect records and among those the pipeline decided (named or
nothing missing), every wrong name, the named effects' residual over the noise floor
and parameter errors, the controls and out-of-library records that got a name (target
0) with what the pipeline says remains, and the wall times. A joint row: viscous
friction hidden in a 10 and a 60 rpm record (1 s each, noise x3), each alone, then
both fitted jointly (one friction law).
``bench/bench_discrepancy_random.py`` is the validation on the drawn scenario space;
this fixed matrix is its regression check.

    .venv/bin/python bench/bench_discrepancy_matrix.py [--quick | --full] [--duration 3]
        [--only FAMILIES] [--conditions 25rpm,step] [--no-joint]

``make bench`` runs the quick set (the default, 47 records).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import statistics
import sys
import time
from collections import Counter, defaultdict
from dataclasses import dataclass
from pathlib import Path

import validation_doc

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / 'src' / 'tribo_estimation'))

from tribo_estimation.core.config import load_rig_config  # noqa: E402
from tribo_estimation.core.discrepancy import (  # noqa: E402
    MissingPhysics,
    Policy,
    find_missing_physics,
)
from tribo_estimation.core.discrepancy import candidates as cand_lib  # noqa: E402
from tribo_estimation.core.model import DriveProfile, Extensions  # noqa: E402
from tribo_estimation.core.record import RigRecord  # noqa: E402
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
#: Verdict columns besides the families.
IN_SET, OTHER_SET, NOTHING = 'in set', 'other set', 'nothing'
VERDICT_COLUMNS = (IN_SET, OTHER_SET, NOTHING, 'unexplained', 'instrument')


def hidden_form(family: str) -> str:
    """Return the form of ``family`` the matrix hides: the first with hidden values.

    A rig file config/rig_hidden_<form>.yaml or the form's demo values; the reference
    simulator has the forms of the original library.
    """
    for c in cand_lib.forms(family):
        if (CONFIG / f'rig_hidden_{c.name}.yaml').is_file() or c.demo_effects is not None:
            return c.name
    raise ValueError(f'family {family}: no form with a rig_hidden file or demo values')


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
    """Return the (hidden family, magnitude scale, condition) cases to run.

    ``quick``: both magnitudes at 25 rpm, the realistic one with the speed step and
    noise x3; controls at 25 rpm, the step, 60 rpm (and the control at 10 rpm and with
    the 5 ms lag).
    """
    conds = ['25rpm', 'step', '10rpm', '60rpm', 'startup', 'lag5ms', 'noise3']
    out = []
    for c in cand_lib.families():
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


@dataclass(frozen=True)
class CaseRow:
    """One record of the matrix: what was hidden and the pipeline's answer.

    ``outcome``: the first named family or a verdict column (:data:`VERDICT_COLUMNS`);
    ``named`` the named families, ``apart`` the set the record cannot tell apart,
    ``experiment`` what would decide; ``rms_baseline``/``rms_final``/``floor``: the
    baseline's and final model's torque residual rms and the generator's noise
    [N m]; ``perr``: worst relative parameter error of the hidden form when named [-];
    ``wall``: pipeline time [s]; ``remains``: what the pipeline reports unexplained.
    """

    hidden: str
    scale: float
    cond: str
    verdict: str
    outcome: str
    named: tuple[str, ...]
    apart: tuple[str, ...]
    experiment: str
    rms_baseline: float
    rms_final: float
    floor: float
    perr: float
    wall: float
    remains: str


@dataclass(frozen=True)
class JointRow:
    """The joint row: per record alone (verdict, fitted viscous [N m s/rad]), then jointly."""

    singles: tuple[tuple[str, float], ...]
    verdict: str
    named: tuple[str, ...]
    fit: float
    perr: float
    reason: str
    wall_single: float
    wall_joint: float


def outcome(res: MissingPhysics, truth: str) -> str:
    """Return the matrix column of a result: the first named family or the verdict's column."""
    if res.verdict == 'named':
        return res.added[0]
    if res.verdict == 'cannot_tell_apart':
        return IN_SET if truth in {e.family for e in res.alternatives} else OTHER_SET
    if res.verdict == 'nothing_missing':
        return NOTHING
    return res.verdict


def fitted(res: MissingPhysics, family: str, param: str) -> float:
    """Return a family's fitted parameter: named, in the set, partial or screened (NaN: none)."""
    for e in (*res.named, *res.alternatives, *res.partial, *(e for r in res.rounds for e in r)):
        if e.family == family and param in e.params:
            return float(e.params[param])
    return math.nan


def as_record(spec: RecordSpec) -> RigRecord:
    """Generate a record and return its measured channels, time from 0."""
    r = make_record(spec)
    return RigRecord(r.time - r.time[0], r.torsion_moment, r.angular_acceleration, r.speed)


def run_case(h: str, scale: float, cond: str, duration: float, seed: int) -> CaseRow:
    """Generate one record with family ``h`` hidden and run the pipeline on it; one row."""
    prof, start, w_nom, lag, noise = condition(cond, duration)
    tc, ac, sc = rig_channels(noise, speed_lag=lag)
    form = hidden_form(h) if h not in (CONTROL, *OUTSIDE) else ''
    truth = hidden(form, scale) if form else {}
    un = Unmodelled()
    if h == BACKLASH:
        un = Unmodelled(backlash=0.01)  # rad, full width (the static deflection ~0.014 rad)
    elif h == C1_DRIFT:
        un = Unmodelled(stiffness_drift=0.02 / (start + duration))  # +2 % by the record end
    rec = as_record(
        RecordSpec(CFG.rig, CFG.friction, prof, extensions=Extensions(**truth), unmodelled=un,
                   torsion=tc, accel=ac, speed=sc, seed=seed, duration=duration,
                   start_offset=start)
    )  # fmt: skip
    drive = DriveProfile(w_nom, 0.2 if start == 0 else 0.0)
    t0 = time.perf_counter()
    res = find_missing_physics([rec], CFG.rig, [drive], k=CFG.friction.k,
                               policy=Policy(max_effects=1))  # fmt: skip
    wall = time.perf_counter() - t0
    perr = math.nan
    if res.named and res.named[0].form == form:
        errs = [
            abs(res.named[0].params[n] / truth[n] - 1.0)
            for n in cand_lib.get(form).param_names
            if truth.get(n, 0.0) != 0.0 and n != 'ripple_phase'
        ]
        perr = max(errs) if errs else math.nan
    rep = res.records[0]
    return CaseRow(
        hidden=h,
        scale=scale,
        cond=cond,
        verdict=res.verdict,
        outcome=outcome(res, h),
        named=res.added,
        apart=tuple(e.family for e in res.alternatives),
        experiment=res.experiment,
        rms_baseline=rep.rms_baseline,
        rms_final=rep.rms_final,
        floor=FLOOR * noise,
        perr=perr,
        wall=wall,
        remains='; '.join(f'{u.kind} {u.where} {u.size:.3g} N m' for u in rep.unexplained),
    )


#: The joint row: viscous friction [N m s/rad] hidden in 1 s records at 10 and 60 rpm of
#: one contact, noise x3.
JOINT_VISCOUS, JOINT_SPEEDS, JOINT_NOISE, JOINT_DURATION = 0.009, (10.0, 60.0), 3.0, 1.0


def run_joint_case(seed: int) -> JointRow:
    """Each record alone, then the joint fit (one friction law, viscous shared)."""
    tc, ac, sc = rig_channels(JOINT_NOISE)
    recs, drives = [], []
    for s in JOINT_SPEEDS:
        recs.append(as_record(
            RecordSpec(CFG.rig, CFG.friction, SpeedProfile.startup(rpm(s), 0.2),
                       extensions=Extensions(viscous=JOINT_VISCOUS), torsion=tc, accel=ac,
                       speed=sc, seed=seed + int(s), duration=JOINT_DURATION, start_offset=0.5)
        ))  # fmt: skip
        drives.append(DriveProfile(rpm(s), 0.0))
    pol = Policy(families=('viscous_friction',), max_effects=1)
    t0 = time.perf_counter()
    singles = []
    for rec, drv in zip(recs, drives, strict=True):
        res = find_missing_physics([rec], CFG.rig, [drv], k=CFG.friction.k, policy=pol)
        singles.append((res.verdict, fitted(res, 'viscous_friction', 'viscous')))
    t1 = time.perf_counter()
    jr = find_missing_physics(recs, CFG.rig, drives, k=CFG.friction.k, policy=pol,
                              shared_friction=True)  # fmt: skip
    t2 = time.perf_counter()
    fit = fitted(jr, 'viscous_friction', 'viscous')
    return JointRow(
        singles=tuple(singles),
        verdict=jr.verdict,
        named=jr.added,
        fit=fit,
        perr=abs(fit / JOINT_VISCOUS - 1.0),
        reason=jr.reason,
        wall_single=t1 - t0,
        wall_joint=t2 - t1,
    )


def _median(xs: list[float]) -> float:
    return statistics.median(xs) if xs else math.nan


def report(rows: list[CaseRow], duration: float, quick: bool) -> None:
    """Print the matrix and the figures of the module docstring."""
    families = list(cand_lib.families())
    cols = [*families, *VERDICT_COLUMNS]
    short = {c: c[:9] for c in cols}
    counts: dict[str, Counter[str]] = defaultdict(Counter)
    for r in rows:
        counts[r.hidden][r.outcome] += 1
    print(f'\nConfusion matrix ({len(rows)} records of {duration:g} s'
          f'{", --quick" if quick else ""}); rows hidden family, columns the verdict')  # fmt: skip
    print(f'{"hidden":<20s}' + ''.join(f'{short[c]:>10s}' for c in cols))
    for h in (*families, CONTROL, *OUTSIDE):
        if counts[h]:
            print(f'{h:<20s}' + ''.join(f'{counts[h][c] or ".":>10}' for c in cols))
    effect_rows = [r for r in rows if r.hidden in families]
    right = [r for r in effect_rows if r.named[:1] == (r.hidden,)]
    decided = [r for r in effect_rows if r.verdict in ('named', 'nothing_missing')]
    right_decided = [r for r in decided if r.named[:1] == (r.hidden,)]
    in_set = [r for r in effect_rows if r.outcome == IN_SET]
    print(
        f'\nhidden family named: {len(right)}/{len(effect_rows)} effect records; among '
        f'the {len(decided)} the pipeline decided (named or nothing missing): '
        f'{len(right_decided)} ({100 * len(right_decided) / max(len(decided), 1):.0f} %); '
        f'a set holding it: {len(in_set)}'
    )
    wrong = [r for r in effect_rows if r.named and r.named[0] != r.hidden]
    print(f'wrong family named: {len(wrong)}')
    for r in wrong:
        print(f'  {r.hidden} x{r.scale:g} {r.cond}: named {", ".join(r.named)}')
    ratios = sorted(r.rms_final / r.floor for r in right)
    perrs = sorted(r.perr for r in right if math.isfinite(r.perr))
    if ratios:
        print(f'named hidden family: residual / noise floor median {_median(ratios):.2f}, worst '
              f'{ratios[-1]:.2f} (target <= 1.5)', end='')  # fmt: skip
        print(
            f'; parameter error median {100 * _median(perrs):.0f} %, worst {100 * perrs[-1]:.0f} %'
            ' (target 20 %)'
            if perrs
            else ''
        )
    ctrl = [r for r in rows if r.hidden in (CONTROL, *OUTSIDE)]
    bad = [r for r in ctrl if r.named]
    print(f'controls and out-of-library records naming a family: {len(bad)}/{len(ctrl)} '
          '(target 0)')  # fmt: skip
    for r in bad:
        print(f'  {r.hidden} {r.cond}: named {", ".join(r.named)} '
              f'(rms {r.rms_baseline:.3f} -> {r.rms_final:.3f} N m)')  # fmt: skip
    for r in ctrl:
        if r.hidden in OUTSIDE and r.remains:
            print(f'  {r.hidden} {r.cond} unexplained: {r.remains[:120]}')
    sets = Counter((r.hidden, r.apart, r.experiment) for r in rows if r.apart)
    if sets:
        print('sets the records cannot tell apart (hidden: set -> experiment): ' + ', '.join(
            f'{h}: {{{", ".join(a)}}} -> {e or "-"} x{n}'
            for (h, a, e), n in sorted(sets.items())))  # fmt: skip
    walls = sorted(r.wall for r in rows)
    print(f'wall time per record: median {_median(walls):.1f} s, worst {walls[-1]:.1f} s')


def main() -> int:
    """Run the matrix and print it; returns the exit code."""
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--quick', action='store_true', help='fewer conditions (47 records; default)')
    ap.add_argument('--full', action='store_true', help='every condition (147 records)')
    ap.add_argument('--duration', type=float, default=3.0, help='record length [s]')
    ap.add_argument('--only', default='', help='comma-separated hidden families to run')
    ap.add_argument('--conditions', default='', help='comma-separated conditions to run')
    ap.add_argument('--no-joint', action='store_true', help='skip the joint row')
    args = ap.parse_args()
    args.quick = not args.full
    # each case keeps its seed (its place in the whole list) when --only picks a few
    todo = [(1000 + i, *c) for i, c in enumerate(cases(args.quick))]
    if args.only:
        keep = set(args.only.split(','))
        todo = [c for c in todo if c[1] in keep]
    if args.conditions:
        conds = set(args.conditions.split(','))
        todo = [c for c in todo if c[3] in conds]
    rows: list[CaseRow] = []
    t_all = time.perf_counter()
    for seed, h, scale, cond in todo:
        r = run_case(h, scale, cond, args.duration, seed=seed)
        rows.append(r)
        extra = f' {{{", ".join(r.apart)}}} -> {r.experiment or "-"}' if r.apart else ''
        print(
            f'{h:<20s} x{scale:<4g} {cond:<8s} -> {r.outcome:<20s}{extra} '
            f'rms {r.rms_baseline:.3f} -> {r.rms_final:.3f} N m ({r.rms_final / r.floor:.2f} '
            f'floor) perr {r.perr:.2f} {r.wall:.1f} s',
            flush=True,
        )
    if rows:
        report(rows, args.duration, args.quick)
    if not args.no_joint:
        j = run_joint_case(seed=7)
        sing = ', '.join(
            f'{s:g} rpm: {verdict} ({fit:.4g})'
            for s, (verdict, fit) in zip(JOINT_SPEEDS, j.singles, strict=True)
        )
        print(
            f'\njoint row: viscous_friction {JOINT_VISCOUS:g} N m s/rad hidden at '
            f'{" + ".join(f"{s:g}" for s in JOINT_SPEEDS)} rpm ({JOINT_DURATION:g} s each, '
            f'noise x{JOINT_NOISE:g}); alone: {sing}; joint (one friction law): {j.verdict} '
            f'{", ".join(j.named) or "-"}, fitted {j.fit:.4g} (error {100 * j.perr:.0f} %, '
            f'target 20 %); {j.reason}; wall {j.wall_single:.1f} s alone, '
            f'{j.wall_joint:.1f} s joint'
        )
    print(f'total {time.perf_counter() - t_all:.0f} s (generation included)')
    return 0


if __name__ == '__main__':
    sys.exit(validation_doc.run(__file__, main))
