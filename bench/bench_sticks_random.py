"""Stick detection against the true stick flags of randomly drawn scenarios.

Each seed draws a scenario of the independent generator (``validation/tribo_scenarios``:
its own equations and integrator, rigs, sample rates 2-20 kHz, drive profiles with
steps, sweeps and stops, instrument chains with lags, gains, hum and coloured noise);
the record and the user's RIG.yaml go through the project's checked input stage
(``te.read_record``, ``te.load_rig``) and :func:`tribo_estimation.core.sticks.find_sticks`.
Per record, against the generator's true stick flag per sample:

- precision: the share of the samples detected as stuck that are stuck (none
  detected: not counted);
- recall: the share of the stuck samples detected (never stuck: not counted);
- false starts: phases whose sample 3 ms in (or its middle, if shorter) is not
  stuck, where a discrepancy segment would start from a wrong state.

Prints the rates per sample rate and over all records, with the worst record.

    .venv/bin/python bench/bench_sticks_random.py [--seeds 0-69]
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import tempfile
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
for _p in ('validation', 'src/tribo_estimation', 'src/tribo_common'):
    sys.path.insert(0, str(ROOT / _p))
sys.path.insert(0, str(ROOT / 'bench'))

import validation_doc  # noqa: E402
from tribo_scenarios import draw, generate  # noqa: E402

import tribo_estimation as te  # noqa: E402
from tribo_estimation.core.sticks import find_sticks  # noqa: E402

#: Where a discrepancy segment starts after a phase's first sample [s].
SEGMENT_DELAY = 3e-3


@dataclass(frozen=True)
class Score:
    """Detection of one record against its truth (module docstring)."""

    seed: int
    fs_label: str
    precision: float
    recall: float
    false_starts: int
    phases: int


def score(seed: int, work: Path) -> Score:
    """Return the detection score of one drawn scenario."""
    sc = generate(draw(seed))
    directory = work / str(seed)
    sc.write_dir(directory)
    rec = te.read_record(directory / 'record.csv')
    rig = te.load_rig(directory / 'rig.yaml').rig
    truth = np.asarray(sc.stick, dtype=bool)
    rep = find_sticks(rec.time, rec.torsion_moment, rec.angular_acceleration, rec.speed, rig)
    detected = np.zeros(truth.size, dtype=bool)
    t0, fs = float(rec.time[0]), rec.fs
    false_starts = 0
    for p in rep.sticks:
        a = int(np.ceil((p.start - t0) * fs))
        b = int(np.ceil((p.end - t0) * fs))
        detected[a:b] = True
        at = a + min(round(SEGMENT_DELAY * fs), (b - a) // 2)
        false_starts += int(at < truth.size and not truth[at])
    both = int(np.count_nonzero(detected & truth))
    n_det, n_true = int(np.count_nonzero(detected)), int(np.count_nonzero(truth))
    precision = both / n_det if n_det else math.nan  # nothing detected: no precision
    recall = both / n_true if n_true else math.nan  # never stuck: no recall
    return Score(seed, sc.labels['fs'], precision, recall, false_starts, len(rep.sticks))


def _seeds(text: str) -> list[int]:
    a, _, b = text.partition('-')
    return list(range(int(a), int(b or a) + 1))


def _row(name: str, rows: list[Score]) -> str:
    prec = [r.precision for r in rows if math.isfinite(r.precision)] or [math.nan]
    rec = [r.recall for r in rows if math.isfinite(r.recall)] or [math.nan]
    starts = sum(r.false_starts for r in rows) / max(sum(r.phases for r in rows), 1)
    return (
        f'{name:<10s} {len(rows):4d} {statistics.mean(prec):9.3f} {min(prec):8.3f} '
        f'{statistics.mean(rec):9.3f} {min(rec):8.3f} {100 * starts:12.2f}'
    )


def main() -> int:
    """Score the stick detector on the drawn scenarios; returns the exit code."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--seeds', default='0-69', help='seeds A-B (inclusive) (0-69)')
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        rows = [score(s, Path(tmp)) for s in _seeds(args.seeds)]
    print(f'seeds {args.seeds}: precision and recall per sample, false segment starts')
    print(
        f'{"fs":<10s} {"n":>4s} {"precision":>9s} {"worst":>8s} {"recall":>9s} {"worst":>8s} '
        f'{"false st. %":>12s}'
    )
    by_fs: dict[str, list[Score]] = defaultdict(list)
    for r in rows:
        by_fs[r.fs_label].append(r)
    for name in sorted(by_fs, key=lambda x: float(x.rstrip('kHz'))):
        print(_row(name, by_fs[name]))
    print(_row('all', rows))
    worst = min(rows, key=lambda r: min(np.nan_to_num([r.precision, r.recall], nan=1.0)))
    print(
        f'worst record: seed {worst.seed} ({worst.fs_label}), precision {worst.precision:.3f}, '
        f'recall {worst.recall:.3f}, {worst.false_starts} false starts of {worst.phases}'
    )
    return 0


if __name__ == '__main__':
    raise SystemExit(validation_doc.run(__file__, main))
