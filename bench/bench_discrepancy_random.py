"""Randomized validation of the missing-physics workflow on independent scenarios.

Each scenario is drawn from the documented space of ``validation/tribo_scenarios``
(a generator that shares no code with the fits; space: its ``space`` module and
docs/validation.md), written as a user would have it (``record.csv`` + the
``rig.yaml`` a lab would pass) into a temporary directory and analysed by
:func:`analyse`, the one function that calls the workflow and translates its answer
into an :class:`Outcome` (the workflow's result type is being redesigned: only
:func:`analyse` changes with it).

Classification per scenario (truth: no effect, one library family, or one effect
outside the library):

- library effect: ``correct`` (only the hidden family named), ``wrong_name`` (a
  family named that is not hidden), ``in_set`` / ``set_wrong`` (nothing named, a
  cannot-tell-apart set with / without the truth), ``undecided`` (nothing named,
  the record reported unable to decide), ``missed`` (nothing named, nothing
  reported undecidable);
- control: ``control_clean`` (nothing named or set) / ``control_false``;
- outside the library: ``ool_clean`` / ``ool_named``;
- ``error``: the command failed (exit code != 0).

An effect scenario is *decided* when the workflow named something or claimed
there is nothing (``correct``, ``wrong_name``, ``missed``). Reported: the issue's
targets with met / not met, rates per condition label (rig, sample rate, drive,
instrument, config, family, form, motion, effect magnitude), the worst cases (every
wrong answer, the clearest effects missed or undecided, the worst residuals and
parameter errors, the slowest runs) and the timing; never a best case.

    python bench/bench_discrepancy_random.py [--n 200 | --seeds A-B,C | --fresh]
        [--workers 2] [--duration S] [--log results.jsonl] [--keep DIR]
    python bench/bench_discrepancy_random.py --from-log results.jsonl   (report again)

Default: seeds 0-199 (the fixed list); ``--fresh`` draws new seeds and prints them.
Records are cached by the generator (``.cache/scenarios/``); the workflow is not.
``make bench`` (or ``TRIBO_WRITE_VALIDATION=1``) writes the printed figures into
docs/validation.md (``bench/validation_doc.py``).
"""

from __future__ import annotations

import os

# one numerical thread per worker process (the workers are the parallelism)
for _var in ('OMP_NUM_THREADS', 'OPENBLAS_NUM_THREADS', 'MKL_NUM_THREADS', 'NUMBA_NUM_THREADS'):
    os.environ.setdefault(_var, '1')

import argparse  # noqa: E402
import contextlib  # noqa: E402
import dataclasses  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import random  # noqa: E402
import shutil  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections import Counter, defaultdict  # noqa: E402
from collections.abc import Callable, Iterable, Sequence  # noqa: E402
from concurrent.futures import ProcessPoolExecutor, as_completed  # noqa: E402
from dataclasses import dataclass, field  # noqa: E402
from pathlib import Path  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ('tribo_common', 'tribo_estimation', 'tribo_bringup', 'tribo_nvct', 'tribo_drivers')
for _p in ('validation', *(f'src/{p}' for p in PACKAGES)):
    sys.path.insert(0, str(ROOT / _p))
sys.path.insert(0, str(ROOT / 'bench'))

import validation_doc  # noqa: E402


@dataclass(frozen=True)
class Outcome:
    """The workflow's answer on one record.

    ``named`` the effects named (in the order added); ``sets`` cannot-tell-apart sets
    (the truth is one of them); ``undecidable`` effects reported not identifiable or too
    small for this record; ``unexplained`` residual structure reported that no
    candidate explains; ``baseline_ratio`` / ``final_ratio`` the baseline's / final
    model's torsion-moment residual rms over the workflow's noise floor [-]; ``params``
    the named effects' parameters (SI); ``seconds`` wall time of the command [s];
    ``error`` the command's last line when it failed ('' otherwise); ``cpu_seconds``
    the command's CPU time in this process [s] (single-threaded: the wall time of an
    unloaded core).
    """

    named: tuple[str, ...]
    sets: tuple[tuple[str, ...], ...]
    undecidable: tuple[str, ...]
    unexplained: bool
    baseline_ratio: float
    final_ratio: float
    params: dict[str, float]
    seconds: float
    error: str = ''
    cpu_seconds: float = math.nan


#: Wall time after which the workflow fits no further candidate form [s] (it then names a
#: family only if every family was fitted): the bench's bound on a pathological record.
TIME_BUDGET = 120.0


def analyse(scenario_dir: Path) -> Outcome:
    """Run ``tribo discrepancy`` on a scenario as a user does and translate its answer.

    The command (in this process, as ``tribo discrepancy DIR/record.csv --rig
    DIR/rig.yaml --out DIR/discrepancy --no-plots``) reads the record and the user's
    config and runs the workflow; its progress goes to ``DIR/discrepancy.log``.
    ``discrepancy.json`` is translated in either of its layouts:

    - the decision pipeline's (a ``verdict``): ``named`` = ``added``; a set =
      ``cannot_tell_apart`` when that is the verdict; ``undecidable`` = the
      ``partial`` families (or the verdict) when the verdict is ``unexplained`` or
      ``instrument``; ``unexplained`` = such a verdict or any ``unexplained`` item;
    - the forward selection's: ``named`` = ``added``; no sets; ``undecidable`` =
      ``not_identifiable`` (improved but the record cannot separate it) and, when
      nothing is named or blocked, the best candidate of the last round (lowest
      held-out cost) if its ``identifiable`` verdict is no (e.g. "too small against
      the noise for this record to decide"); ``unexplained`` = any ``unexplained``
      item or an ``inconsistent`` candidate.

    Parameters
    ----------
    scenario_dir : Path
        Directory with ``record.csv`` and ``rig.yaml``.

    Returns
    -------
    Outcome
        The answer.
    """
    from tribo_bringup.cli import main as tribo

    out = scenario_dir / 'discrepancy'
    argv = ['discrepancy', str(scenario_dir / 'record.csv'), '--rig',
            str(scenario_dir / 'rig.yaml'), '--out', str(out), '--no-plots',
            '--time-budget', str(TIME_BUDGET)]  # fmt: skip
    t0 = time.perf_counter()
    c0 = time.process_time()
    log = scenario_dir / 'discrepancy.log'
    with log.open('w') as fh, contextlib.redirect_stderr(fh), contextlib.redirect_stdout(fh):
        code = tribo(argv)
    seconds = time.perf_counter() - t0
    cpu = time.process_time() - c0
    if code != 0:
        lines = [s for s in log.read_text().splitlines() if s.strip()]
        last = lines[-1] if lines else f'exit code {code}'
        return Outcome((), (), (), False, math.nan, math.nan, {}, seconds, last, cpu)
    doc = json.loads((out / 'discrepancy.json').read_text())
    added = doc['added']
    named = tuple(str(a['effect']) for a in added)
    params = {str(k): float(v) for a in added for k, v in a['params'].items()}
    floor = float(doc['noise_floor'])
    sets: tuple[tuple[str, ...], ...] = ()
    if 'verdict' in doc:  # the decision pipeline
        verdict = str(doc['verdict'])
        if verdict == 'cannot_tell_apart':
            sets = (tuple(str(e['family']) for e in doc['cannot_tell_apart']),)
        open_ = verdict in ('unexplained', 'instrument')
        partial = tuple(str(e['family']) for e in doc.get('partial', []))
        undecidable = (partial or (verdict,)) if open_ else ()
        unexplained = open_ or bool(doc['unexplained'])
    else:  # the forward selection
        blocked = [str(n) for n in doc.get('not_identifiable', [])]
        if not named and not blocked and doc['rounds']:
            best = min(doc['rounds'][-1], key=lambda c: float(c['cv_cost']))
            verdict_of = doc.get('identifiable', {}).get(best['effect'], {})
            if verdict_of and not verdict_of.get('ok', True):
                blocked.append(str(best['effect']))
        undecidable = tuple(blocked)
        unexplained = bool(doc['unexplained']) or bool(doc.get('inconsistent'))
    return Outcome(
        named=named,
        sets=sets,
        undecidable=undecidable,
        unexplained=unexplained,
        baseline_ratio=float(doc['baseline']['rms']) / floor,
        final_ratio=float(doc['final']['rms']) / floor,
        params=params,
        seconds=seconds,
        cpu_seconds=cpu,
    )


# --------------------------------------------------------------------------- one scenario

#: Classes of an effect scenario that are decisions (something named, or nothing).
DECIDED = ('correct', 'wrong_name', 'missed')
WRONG = ('wrong_name', 'set_wrong', 'control_false', 'ool_named')
#: Targets of issue 21.
T_FIRST, T_DECIDED, T_CONTROL, T_CTRL_BASE, T_FINAL, T_PARAM, T_SECONDS = (
    0.95, 0.80, 0.99, 1.3, 1.5, 0.2, 30.0
)  # fmt: skip


def classify(effect: str, category: str, o: Outcome) -> str:
    """Return the class of one scenario's answer (module docstring).

    Parameters
    ----------
    effect : str
        The hidden effect (family, 'none' or 'out_of_library:<name>').
    category : str
        'none', 'library' or 'out_of_library'.
    o : Outcome
        The workflow's answer.

    Returns
    -------
    str
        The class.
    """
    if o.error:
        return 'error'
    claims = set(o.named) | {n for s in o.sets for n in s}
    if category == 'none':
        return 'control_false' if claims else 'control_clean'
    if category == 'out_of_library':
        return 'ool_named' if claims else 'ool_clean'
    if o.named:
        return 'correct' if set(o.named) == {effect} else 'wrong_name'
    if o.sets:
        return 'in_set' if any(effect in s for s in o.sets) else 'set_wrong'
    return 'undecided' if o.undecidable else 'missed'


def param_error(truth: dict[str, float], fitted: dict[str, float]) -> float:
    """Return the worst relative error of the named parameters against the truth [-].

    Parameters
    ----------
    truth : dict
        The hidden effect's parameters under the library's names (own form only).
    fitted : dict
        The workflow's fitted parameters.

    Returns
    -------
    float
        max |fitted/true - 1| over the parameters both have (NaN if none).
    """
    errs = [abs(fitted[k] / v - 1.0) for k, v in truth.items() if k in fitted and v != 0.0]
    return max(errs) if errs else math.nan


@dataclass(frozen=True)
class Row:
    """One scenario's result (a line of ``--log``).

    ``effect``, ``category``, ``form``, ``own_form``, ``snr`` (effect_snr [-]) the truth;
    ``labels`` its condition labels; ``outcome`` the answer; ``cls`` its class;
    ``perr`` the parameter error (:func:`param_error`); ``noise_rms`` the torque noise
    the generator added (white + coloured + hum, rms) [N m]; ``gen_seconds`` the
    generator's simulation time [s]; ``duration`` [s].
    """

    seed: int
    effect: str
    category: str
    form: str
    own_form: bool
    snr: float
    labels: dict[str, str]
    outcome: Outcome
    cls: str
    perr: float
    noise_rms: float
    gen_seconds: float
    duration: float
    truth_params: dict[str, float] = field(default_factory=dict)


def run_scenario(seed: int, duration: float | None, keep: str | None) -> Row:
    """Generate one scenario (cached), write it as a user has it, analyse and classify it.

    Parameters
    ----------
    seed : int
        Scenario seed.
    duration : float or None
        Record duration [s] (None: drawn).
    keep : str or None
        Keep the scenario's directory under this path (None: a removed temp dir).

    Returns
    -------
    Row
        The result.
    """
    from tribo_scenarios import draw, generate

    spec = draw(seed, duration=duration)
    sc = generate(spec)
    if keep:
        d = Path(keep) / str(seed)
        shutil.rmtree(d, ignore_errors=True)
    else:
        d = Path(tempfile.mkdtemp(prefix=f'tribo_random_{seed}_'))
    try:
        sc.write_dir(d)
        try:
            o = analyse(d)
        except Exception as exc:  # a failure of the bench's translation, not of the command
            o = Outcome((), (), (), False, math.nan, math.nan, {}, math.nan,
                        f'bench: {type(exc).__name__}: {exc}')  # fmt: skip
    finally:
        if not keep:
            shutil.rmtree(d, ignore_errors=True)
    tr = sc.truth
    cls = classify(tr.effect, tr.category, o)
    perr = param_error(tr.library_params, o.params) if cls == 'correct' else math.nan
    return Row(
        seed=seed,
        effect=tr.effect,
        category=tr.category,
        form=tr.form,
        own_form=tr.own_form,
        snr=tr.effect_snr,
        labels=dict(sc.labels),
        outcome=o,
        cls=cls,
        perr=perr,
        noise_rms=tr.noise_rms['torque'],
        gen_seconds=sc.gen_seconds,
        duration=spec.duration,
        truth_params=dict(tr.library_params or tr.params),
    )


# --------------------------------------------------------------------------- the report


def _pct(k: int, n: int) -> str:
    return f'{k}/{n} ({100.0 * k / n:.0f} %)' if n else '0/0 (-)'


def _med(xs: Iterable[float]) -> float:
    v = [x for x in xs if math.isfinite(x)]
    return statistics.median(v) if v else math.nan


def _worst(xs: Iterable[float]) -> float:
    v = [x for x in xs if math.isfinite(x)]
    return max(v) if v else math.nan


def _cost(r: Row) -> float:
    """Return the workflow's CPU time of a row [s] (its wall time if not measured)."""
    c = r.outcome.cpu_seconds
    return c if math.isfinite(c) else r.outcome.seconds


def _met(ok: bool, n: int = 1) -> str:
    """Return 'met' / 'NOT met', or 'no case' when nothing was there to judge."""
    if n == 0:
        return 'no case'
    return 'met' if ok else 'NOT met'


def _describe(r: Row) -> str:
    o = r.outcome
    said = (
        f'error: {o.error}'
        if o.error
        else f'named {",".join(o.named) or "-"}'
        + (f'; sets {o.sets}' if o.sets else '')
        + (f'; undecidable {",".join(o.undecidable)}' if o.undecidable else '')
        + ('; unexplained' if o.unexplained else '')
    )
    lab = r.labels
    return (
        f'seed {r.seed}: {r.effect} ({r.form}, snr {r.snr:.3g}) {lab["drive"]} {lab["fs"]} '
        f'{lab["motion"]} {r.duration:.1f} s, speed lag {lab["speed_lag"]}, shaft config '
        f'{lab["config_shaft"]}, k {lab["config_k"]} -> {said}; baseline '
        f'{o.baseline_ratio:.2f}x, final {o.final_ratio:.2f}x floor, {_cost(r):.0f} s CPU '
        f'({o.seconds:.0f} s wall)'
    )


def targets(rows: Sequence[Row]) -> list[str]:
    """Return the lines of the issue's target figures, each with met / not met.

    Parameters
    ----------
    rows : sequence of Row
        The results.

    Returns
    -------
    list of str
        Report lines.
    """
    eff = [r for r in rows if r.category == 'library']
    dec = [r for r in eff if r.cls in DECIDED]
    first = [r for r in dec if r.outcome.named and r.outcome.named[0] == r.effect]
    wrong_eff = [r for r in eff if r.cls in ('wrong_name', 'set_wrong')]
    ctrl = [r for r in rows if r.category == 'none']
    ctrl_clean = [r for r in ctrl if r.cls == 'control_clean']
    ctrl_base = [r.outcome.baseline_ratio for r in ctrl if not r.outcome.error]
    ool = [r for r in rows if r.category == 'out_of_library']
    ool_named = [r for r in ool if r.cls == 'ool_named']
    named_ok = [r for r in eff if r.cls == 'correct']
    finals = [r.outcome.final_ratio for r in named_ok]
    perrs = [r.perr for r in named_ok if r.own_form and math.isfinite(r.perr)]
    secs = [_cost(r) for r in rows]
    f_rate = len(first) / len(dec) if dec else math.nan
    d_rate = len(dec) / len(eff) if eff else math.nan
    c_rate = len(ctrl_clean) / len(ctrl) if ctrl else math.nan
    return [
        f'first named = hidden, of decided effect scenarios: {_pct(len(first), len(dec))} '
        f'(target >= {T_FIRST:.0%}): {_met(f_rate >= T_FIRST, len(dec))}',
        f'decided, of effect scenarios: {_pct(len(dec), len(eff))} (target >= '
        f'{T_DECIDED:.0%}): {_met(d_rate >= T_DECIDED, len(eff))}',
        f'wrong names on effect scenarios: {len(wrong_eff)} (target 0): '
        f'{_met(not wrong_eff, len(eff))}',
        f'controls with nothing named: {_pct(len(ctrl_clean), len(ctrl))} (target >= '
        f'{T_CONTROL:.0%}): {_met(c_rate >= T_CONTROL, len(ctrl))}',
        f'control baseline / noise floor: median {_med(ctrl_base):.2f}, worst '
        f'{_worst(ctrl_base):.2f} (target <= {T_CTRL_BASE}): '
        f'{_met(_worst(ctrl_base) <= T_CTRL_BASE, len(ctrl_base))}',
        f'out-of-library records named: {_pct(len(ool_named), len(ool))} (target 0): '
        f'{_met(not ool_named, len(ool))}',
        f'residual after adding / noise floor (correct names): median {_med(finals):.2f}, '
        f'worst {_worst(finals):.2f} (target <= {T_FINAL}): '
        f'{_met(_worst(finals) <= T_FINAL, len(finals))}',
        f'named parameters, own forms ({len(perrs)}): median error {100 * _med(perrs):.1f} %, '
        f'worst {100 * _worst(perrs):.1f} % (target {T_PARAM:.0%}): '
        f'{_met(_worst(perrs) <= T_PARAM, len(perrs))}',
        f'workflow CPU time per record ({_med(r.duration for r in rows):.1f} s median '
        f'length, one core): median {_med(secs):.1f} s, worst {_worst(secs):.1f} s (target <= '
        f'{T_SECONDS:g} s per 8 s record): {_met(_worst(secs) <= T_SECONDS, len(secs))}',
    ]


def per_condition(rows: Sequence[Row]) -> list[str]:
    """Return the rate table per condition label.

    Columns: records; effect records; decided %; first named = hidden of decided;
    wrong names (effect); controls clean; out-of-library clean; median final ratio of
    correct names; median workflow CPU seconds.

    Parameters
    ----------
    rows : sequence of Row
        The results.

    Returns
    -------
    list of str
        Report lines.
    """
    out = [
        f'{"label=value":<34s}{"n":>4s}{"eff":>5s}{"decided":>9s}{"first=hid":>11s}'
        f'{"wrong":>6s}{"ctrl ok":>9s}{"ool ok":>8s}{"final":>7s}{"sec":>6s}'
    ]
    keys = sorted({k for r in rows for k in r.labels})
    for key in keys:
        groups: dict[str, list[Row]] = defaultdict(list)
        for r in rows:
            groups[r.labels.get(key, '?')].append(r)
        for val in sorted(groups):
            g = groups[val]
            eff = [r for r in g if r.category == 'library']
            dec = [r for r in eff if r.cls in DECIDED]
            first = [r for r in dec if r.outcome.named and r.outcome.named[0] == r.effect]
            wrong = sum(r.cls in ('wrong_name', 'set_wrong') for r in eff)
            ctrl = [r for r in g if r.category == 'none']
            ool = [r for r in g if r.category == 'out_of_library']
            fin = _med(r.outcome.final_ratio for r in eff if r.cls == 'correct')

            def frac(k: int, n: int) -> str:
                return f'{k}/{n}' if n else '-'

            out.append(
                f'{(key + "=" + val)[:33]:<34s}{len(g):>4d}{len(eff):>5d}'
                f'{frac(len(dec), len(eff)):>9s}{frac(len(first), len(dec)):>11s}{wrong:>6d}'
                f'{frac(sum(r.cls == "control_clean" for r in ctrl), len(ctrl)):>9s}'
                f'{frac(sum(r.cls == "ool_clean" for r in ool), len(ool)):>8s}'
                f'{fin:>7.2f}{_med(_cost(r) for r in g):>6.0f}'
            )
    return out


def worst_cases(rows: Sequence[Row]) -> list[str]:
    """Return the worst cases: every wrong answer and error, then the worst of each kind.

    Parameters
    ----------
    rows : sequence of Row
        The results.

    Returns
    -------
    list of str
        Report lines.
    """
    out: list[str] = []

    def section(title: str, sel: Sequence[Row]) -> None:
        out.append(f'{title}: {len(sel)}' + ('' if sel else ' (none)'))
        out.extend(f'  {_describe(r)}' for r in sel)

    section('wrong answers', [r for r in rows if r.cls in WRONG])
    section('errors', [r for r in rows if r.cls == 'error'])
    by_snr = sorted((r for r in rows if r.cls == 'missed'), key=lambda r: -r.snr)
    section('missed (nothing named, nothing undecidable), clearest 5', by_snr[:5])
    und = sorted((r for r in rows if r.cls == 'undecided'), key=lambda r: -r.snr)
    section('undecided, clearest 5', und[:5])
    fin = sorted((r for r in rows if r.cls == 'correct'), key=lambda r: -r.outcome.final_ratio)
    section('correct names with the largest residual, 3', fin[:3])
    pe = sorted((r for r in rows if math.isfinite(r.perr)), key=lambda r: -r.perr)
    out.append(f'largest parameter errors (own forms), 3: {len(pe)}')
    out.extend(
        f'  seed {r.seed}: {r.effect} truth {r.truth_params} fitted '
        f'{ {k: r.outcome.params[k] for k in r.truth_params if k in r.outcome.params} } '
        f'({100 * r.perr:.0f} %)'
        for r in pe[:3]
    )
    ctrl = sorted((r for r in rows if r.category == 'none' and not r.outcome.error),
                  key=lambda r: -r.outcome.baseline_ratio)  # fmt: skip
    section('controls with the largest baseline residual, 3', ctrl[:3])
    slow = sorted(rows, key=lambda r: -_cost(r))
    section('slowest, 3', slow[:3])
    return out


def report(
    rows: Sequence[Row], wall: float, args: argparse.Namespace, seeds: Sequence[int]
) -> None:
    """Print the whole report (stdout).

    Parameters
    ----------
    rows : sequence of Row
        The results.
    wall : float
        Total wall time [s].
    args : argparse.Namespace
        The command line.
    seeds : sequence of int
        The seeds run.
    """
    from tribo_scenarios import GENERATOR_VERSION

    cls = Counter(r.cls for r in rows)
    cats = Counter(r.category for r in rows)
    print(
        f'machine: {platform.node()} ({platform.machine()}, {os.cpu_count()} cores, Python '
        f'{platform.python_version()}); generator {GENERATOR_VERSION}; {len(rows)} scenarios '
        f'(seeds {_seed_text(seeds)}), {args.workers} workers, duration '
        f'{"drawn 4-8 s" if args.duration is None else f"{args.duration:g} s"}'
        + (f'; wall {wall / 60:.1f} min' if math.isfinite(wall) else '')
    )
    print(
        f'truth: {cats["library"]} library effects, {cats["none"]} controls, '
        f'{cats["out_of_library"]} out of the library; classes: '
        + ', '.join(f'{k} {v}' for k, v in sorted(cls.items()))
    )
    print('\ntargets (issue 21):')
    for line in targets(rows):
        print(f'  {line}')
    print('\nper condition:')
    for line in per_condition(rows):
        print(f'  {line}')
    print('\nworst cases:')
    for line in worst_cases(rows):
        print(f'  {line}')
    gen = [r.gen_seconds for r in rows]
    secs = [r.outcome.seconds for r in rows]
    cpu = [_cost(r) for r in rows]
    print(
        f'\ntiming: generator median {_med(gen):.2f} s, worst {_worst(gen):.2f} s per record '
        f'(wall, when first made); workflow CPU median {_med(cpu):.1f} s, worst '
        f'{_worst(cpu):.1f} s; wall median {_med(secs):.1f} s, worst {_worst(secs):.1f} s '
        f'(load average at the end {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)'
    )


def _seed_text(seeds: Sequence[int]) -> str:
    s = list(seeds)
    if s and s == list(range(s[0], s[0] + len(s))):
        return f'{s[0]}-{s[-1]}'
    return ','.join(map(str, s))


def _parse_seeds(text: str) -> list[int]:
    seeds: list[int] = []
    for part in text.split(','):
        lo, dash, hi = part.partition('-')
        hi = hi if dash else lo
        if not (lo.isdigit() and hi.isdigit()) or int(hi) < int(lo):
            raise argparse.ArgumentTypeError(
                f'--seeds wants A-B or a comma list of them (0 <= A <= B), got {text!r}'
            )
        seeds.extend(range(int(lo), int(hi) + 1))
    return sorted(set(seeds))


def _row_json(r: Row) -> str:
    def clean(x: object) -> object:
        if isinstance(x, float) and not math.isfinite(x):
            return None
        if isinstance(x, dict):
            return {k: clean(v) for k, v in x.items()}
        if isinstance(x, list | tuple):
            return [clean(v) for v in x]
        return x

    return json.dumps(clean(dataclasses.asdict(r)))


def read_log(path: str) -> list[Row]:
    """Return the rows of a ``--log`` file (JSON lines; null is NaN).

    Parameters
    ----------
    path : str
        The log.

    Returns
    -------
    list of Row
        The rows in seed order.
    """

    def num(x: object) -> float:
        return math.nan if x is None else float(str(x))

    rows = []
    for line in Path(path).read_text().splitlines():
        d = json.loads(line)
        o = d['outcome']
        out = Outcome(
            tuple(o['named']),
            tuple(tuple(x) for x in o['sets']),
            tuple(o['undecidable']),
            bool(o['unexplained']),
            num(o['baseline_ratio']),
            num(o['final_ratio']),
            {k: num(v) for k, v in o['params'].items()},
            num(o['seconds']),
            str(o['error']),
            num(o.get('cpu_seconds')),
        )
        rows.append(
            Row(
                d['seed'],
                d['effect'],
                d['category'],
                d['form'],
                bool(d['own_form']),
                num(d['snr']),
                dict(d['labels']),
                out,
                d['cls'],
                num(d['perr']),
                num(d['noise_rms']),
                num(d['gen_seconds']),
                num(d['duration']),
                {k: num(v) for k, v in d['truth_params'].items()},
            )
        )
    return sorted(rows, key=lambda r: r.seed)


def run_all(
    seeds: Sequence[int],
    workers: int,
    duration: float | None,
    keep: str | None,
    on_row: Callable[[Row], None],
) -> list[Row]:
    """Run every seed (in ``workers`` processes) and return the rows in seed order.

    Parameters
    ----------
    seeds : sequence of int
        Scenario seeds.
    workers : int
        Worker processes (1: in this process).
    duration : float or None
        Record duration [s] (None: drawn).
    keep : str or None
        Directory to keep the scenarios in (None: temporary).
    on_row : callable
        Called with each row as it completes.

    Returns
    -------
    list of Row
        The rows.
    """
    rows: list[Row] = []
    if workers <= 1:
        for s in seeds:
            rows.append(run_scenario(s, duration, keep))
            on_row(rows[-1])
    else:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            futs = [pool.submit(run_scenario, s, duration, keep) for s in seeds]
            for fut in as_completed(futs):
                rows.append(fut.result())
                on_row(rows[-1])
    return sorted(rows, key=lambda r: r.seed)


def main() -> int:
    """Run the bench; returns the exit code."""
    ap = argparse.ArgumentParser(description=(__doc__ or '').split('\n\n')[0])
    ap.add_argument('--n', type=int, default=200, help='number of scenarios (seeds 0..n-1)')
    ap.add_argument('--seeds', type=_parse_seeds, default=None, metavar='A-B,C',
                    help='run seeds A to B (inclusive) and C instead')  # fmt: skip
    ap.add_argument('--fresh', action='store_true', help='draw --n new random seeds (printed)')
    ap.add_argument('--workers', type=int, default=2, help='worker processes (2)')
    ap.add_argument('--duration', type=float, default=None, help='record length [s] (drawn)')
    ap.add_argument('--log', default='', metavar='FILE', help='write each result as a JSON line')
    ap.add_argument(
        '--keep', default=None, metavar='DIR', help='keep each scenario directory (all files)'
    )
    ap.add_argument('--from-log', default='', metavar='FILE',
                    help='report the results of an earlier --log instead of running')  # fmt: skip
    args = ap.parse_args()
    if args.from_log:
        rows = read_log(args.from_log)
        report(rows, math.nan, args, [r.seed for r in rows])
        return 0
    if args.fresh:
        seeds = sorted(random.SystemRandom().sample(range(10_000, 2**31 - 1), args.n))
        print(f'fresh seeds: {" ".join(map(str, seeds))}', file=sys.stderr)
    else:
        seeds = args.seeds if args.seeds is not None else list(range(args.n))
    log = Path(args.log).open('w') if args.log else None  # noqa: SIM115
    t0 = time.perf_counter()
    done = 0

    def on_row(r: Row) -> None:
        nonlocal done
        done += 1
        o = r.outcome
        print(
            f'[{done}/{len(seeds)}] seed {r.seed}: {r.effect} ({r.form}, snr {r.snr:.3g}) -> '
            f'{r.cls}: {",".join(o.named) or o.error or "-"} ({_cost(r):.0f} s CPU, '
            f'{o.seconds:.0f} s wall)',
            file=sys.stderr,
            flush=True,
        )
        if log is not None:
            log.write(_row_json(r) + '\n')
            log.flush()

    try:
        rows = run_all(seeds, args.workers, args.duration, args.keep, on_row)
    finally:
        if log is not None:
            log.close()
    report(rows, time.perf_counter() - t0, args, seeds)
    return 0


if __name__ == '__main__':
    sys.exit(validation_doc.run(__file__, main))
