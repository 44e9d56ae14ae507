"""``tribo friction``: block-wise friction estimation of a recorded session (paper 2.5).

Reads a rig CSV (``time,torsion_moment,angular_acceleration,speed``) or a bag
with the ``/rig/*`` SampleBlock streams, estimates mu0 and mu_inf (Equ. 8) per
block, and writes ``OUT/blocks.csv`` plus the figures ``blocks.png`` (paper
Fig. 4/5 layout), ``mu_slip.png`` (mu versus slip speed) and ``detail.png``
(Fig. 6 style, stick phases shaded). Streaming: memory stays bounded whatever
the length of the session.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from tribo_bringup.argtypes import bounded_float
from tribo_bringup.errors import BagError, BagTruncatedError

if TYPE_CHECKING:
    from tribo_estimation.core.align import AlignEvent
    from tribo_estimation.core.blockfit import BlockDetail, BlockResult

#: Observer samples kept per block for the mu-vs-slip-speed figure.
_POINTS_PER_BLOCK = 60
#: Length of each detail window (Fig. 6) [s].
_DETAIL_S = 0.15


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``friction`` subcommand."""
    p = sub.add_parser(
        'friction',
        help='block-wise mu0/mu_inf estimation of a rig CSV or bag (paper Fig. 4-6)',
        description='Estimate the friction law mu(|v|) = (mu0 - mu_inf)*exp(-k|v|) + mu_inf '
        '(paper Equ. 8) block by block from the torsion moment, the chamber acceleration '
        'and the shaft speed of a recorded session. Writes OUT/blocks.csv (one row per '
        'block, with a quality column: ok or flags gap, saturated, no_sliding, startup, '
        'fit_failed, short, spikes, bursts, repaired; the last columns count the samples '
        'replaced before the fit and the bursts among them: both are left out of the fit, '
        'a block with over 20 % replaced is not fitted; w0, drive_mismatch and speed_offset '
        "give the drive speed used, its deviation from nominal_speed and the speed channel's "
        'offset from the drive speed of the stick lines, which sets the level when it exceeds '
        '1 %) and the figures blocks.png, '
        'mu_slip.png and detail.png. The channels are checked against the rig first: a '
        'torque in N mm, a speed in rpm or a time in ms is named (exit 2); nothing is left '
        'in OUT on an error.',
    )
    p.add_argument(
        'input', help='rig CSV (time,torsion_moment,angular_acceleration,speed in SI) or a bag'
    )
    p.add_argument('--rig', required=True, help='RIG.yaml with the rig parameters (SI)')
    p.add_argument('--out', required=True, help='output directory (created if needed)')
    p.add_argument(
        '--block',
        type=bounded_float(0.01, 600.0, unit='s'),
        default=1.0,
        metavar='S',
        help='block length [s] (default 1.0)',
    )
    p.add_argument('--fit-k', action='store_true', help='also fit the Stribeck constant k [s/rad]')
    p.add_argument(
        '--tacho-speed',
        action='store_true',
        help='do not check the measured drive speed against nominal_speed of RIG.yaml '
        '(the drive speed is always measured from the speed channel)',
    )
    p.add_argument('--no-plots', action='store_true', help='write blocks.csv only')
    p.add_argument('--quiet', action='store_true', help='no progress on stderr')
    p.add_argument(
        '--namespace', metavar='NS', help='rig namespace in the bag (default: its only rig)'
    )
    p.set_defaults(func=run)


def _is_bag(path: Path) -> bool:
    return path.is_dir() or path.suffix in ('.mcap', '.db3')


def csv_events(path: Path, jitter: list[float] | None = None) -> Iterator[AlignEvent]:
    """Aligner events (chunks and gaps) from a rig CSV read block by block.

    The rate comes from the first block (:func:`~tribo_estimation.core.rigio.estimate_rate`;
    epoch or relative stamps); each sample's index from the grid through the previous
    block's last sample, stamps that jitter are resampled onto the grid (largest jitter
    in sample intervals appended to ``jitter``), a time step that skips samples
    becomes a :class:`GapEvent` (never bridged), a sample off the grid is an error
    naming its line.
    """
    from tribo_estimation.core.align import AlignedChunk, GapEvent
    from tribo_estimation.core.rigio import (
        centred_anchor,
        estimate_rate,
        grid_positions,
        iter_rig_csv,
        resample_on_grid,
    )

    fs: float | None = None
    t_first = math.nan
    t_ref = math.nan
    idx_ref = 0
    next_index: int | None = None
    for rec in iter_rig_csv(path, 10_000):
        t = rec.time
        if fs is None:
            fs = estimate_rate(t, str(path))
            t_first = t_ref = centred_anchor(t, fs)
        lines = rec.first_line + np.arange(len(t))
        after = None if next_index is None else next_index - 1
        idx, frac = grid_positions(t, fs, t_ref, idx_ref, str(path), lines, after)
        if jitter is not None and frac.size:
            jitter.append(float(np.max(np.abs(frac))))
        # next grid through this block's last sample, shifted by the block's mean offset
        # (follows a rate that differs from the estimate in its 7th digit, averages jitter)
        t_ref = float(t[-1]) - (float(frac[-1]) - float(np.mean(frac))) / fs
        idx_ref = int(idx[-1])
        chans = [
            resample_on_grid(idx, frac, c)
            for c in (rec.torsion_moment, rec.angular_acceleration, rec.speed)
        ]
        cuts = np.flatnonzero(np.diff(idx) != 1) + 1
        for a, b in zip(np.r_[0, cuts], np.r_[cuts, len(idx)], strict=True):
            a, b = int(a), int(b)
            first = int(idx[a])
            if next_index is not None and first != next_index:
                yield GapEvent(next_index, first, ('csv',), t_first + next_index / fs)
            yield AlignedChunk(
                first,
                t_first + first / fs,
                fs,
                chans[0][a:b],
                chans[1][a:b],
                chans[2][a:b],
            )
            next_index = int(idx[b - 1]) + 1


def bag_events(path: Path, namespace: str | None = None) -> Iterator[AlignEvent]:
    """Read aligner events from the ``rig/*`` SampleBlock streams of a bag.

    Of the rig in ``namespace`` (default: the only rig of the bag)
    (:func:`tribo_bringup.sessions.rig_bag_events`).
    """
    from tribo_bringup.sessions import rig_bag_events

    return rig_bag_events(path, namespace)


class _Collector:
    """Bounded memory summaries for the figures (observer points, detail windows)."""

    def __init__(self, fnr: float) -> None:
        self.fnr = fnr
        self.slip: list[np.ndarray] = []
        self.mu: list[np.ndarray] = []
        self.details: dict[str, Any] = {}
        #: time origin of the figures [s]: bags carry wall-clock stamps, shown from the start
        self.origin: float | None = None

    def add(self, det: BlockDetail) -> None:
        """Keep the figure data of one evaluated block."""
        from tribo_estimation.plots import DetailTrace, time_origin

        d = det.data
        res = det.result
        if self.origin is None:
            self.origin = time_origin(res.t_start)
        if d.moment.size == d.torsion.size and d.torsion.size:
            slide = ~d.stick
            idx = np.flatnonzero(slide)
            if idx.size:
                pick = idx[
                    np.linspace(0, idx.size - 1, min(_POINTS_PER_BLOCK, idx.size)).astype(int)
                ]
                self.slip.append(np.abs(d.speed[pick] - d.chamber_speed[pick]))
                self.mu.append(np.abs(d.moment[pick]) / self.fnr)
        if res.ok and res.motion not in self.details:
            n = min(d.torsion.size, round(_DETAIL_S * d.fs))
            t = d.t0 - self.origin + np.arange(n) / d.fs
            sim = det.simulated[:n] if det.simulated.size >= n else np.full(n, np.nan)
            mom = d.moment[:n] if d.moment.size >= n else np.full(n, np.nan)
            self.details[res.motion] = DetailTrace(
                f'{res.motion}, block at {res.t_start - self.origin:.1f} s',
                t,
                d.torsion[:n].copy(),
                mom.copy(),
                sim.copy(),
                d.stick[:n].copy(),
            )

    def points(self) -> tuple[np.ndarray, np.ndarray]:
        if not self.slip:
            return np.zeros(0), np.zeros(0)
        return np.concatenate(self.slip), np.concatenate(self.mu)


def run(args: argparse.Namespace) -> int:
    """Estimate, write blocks.csv and the figures."""
    from tribo_bringup.outputs import PARTIAL_DIR, atomic_output_dir, keep_as_partial
    from tribo_estimation.core.blockfit import BlockConfig, BlockCsvWriter, BlockEstimator
    from tribo_estimation.core.blockfit.evaluate import SPEED_CHANNEL_TOL
    from tribo_estimation.core.config import load_rig_config
    from tribo_estimation.core.drive import MISMATCH_LIMIT
    from tribo_estimation.core.plausibility import Scales, SpikeLog, checked_chunks

    src = Path(args.input)
    if not src.exists():
        raise BagError(f'{src}: no such file or bag')
    cfg_rig = load_rig_config(args.rig)
    nominal = cfg_rig.drive.nominal_speed
    cfg = BlockConfig(
        block_length=args.block,
        fit_k=bool(args.fit_k),
        nominal_speed=None if args.tacho_speed or nominal <= 0.0 else nominal,
        ramp_time=cfg_rig.drive.ramp_time,
    )
    out = Path(args.out)
    spikes = SpikeLog()
    est = BlockEstimator(cfg_rig.rig, cfg_rig.friction, cfg, repairs=spikes)
    jitter: list[float] = []
    raw_events = bag_events(src, args.namespace) if _is_bag(src) else csv_events(src, jitter)
    scales = Scales.of(cfg_rig.rig, cfg_rig.friction, nominal)
    warnings: list[str] = []
    events = checked_chunks(raw_events, scales, str(src), spikes, warnings)
    fnr = cfg_rig.rig.F_N * cfg_rig.rig.R
    coll = _Collector(fnr if fnr > 0 else 1.0)
    results = []
    t_wall = time.monotonic()
    last_report = t_wall
    with atomic_output_dir(out) as stage, BlockCsvWriter(stage / 'blocks.csv') as writer:

        def handle(det: BlockDetail) -> None:
            nonlocal last_report
            while warnings:
                print(f'friction: warning: {warnings.pop(0)}', file=sys.stderr)
            writer.write(det.result)
            results.append(det.result)
            coll.add(det)
            now = time.monotonic()
            if not args.quiet and (now - last_report > 2.0 or len(results) == 1):
                r = det.result
                print(
                    f'friction: block {r.index} t={r.t_start:.1f} s mu0={r.mu0:.4f} '
                    f'mu_inf={r.mu_inf:.4f} {r.motion} {r.quality_str} '
                    f'({len(results)} blocks, {now - t_wall:.0f} s)',
                    file=sys.stderr,
                )
                last_report = now

        truncated: BagTruncatedError | None = None
        try:
            for ev in events:
                for det in est.feed(ev):
                    handle(det)
        except BagTruncatedError as exc:
            truncated = exc  # the blocks before the damage are kept in OUT/partial/
        if truncated is None:
            for det in est.finish():
                handle(det)
        if not results:
            raise truncated or BagError(f'{src}: no complete block of data')
        if not args.no_plots:
            _plots(stage, results, coll, cfg_rig.friction.k)
        if truncated is not None:
            writer.close()
            keep_as_partial(stage)
    if truncated is not None:
        raise BagTruncatedError(f'{truncated} (blocks before it in {out / PARTIAL_DIR})')
    for w in warnings:
        print(f'friction: warning: {w}', file=sys.stderr)
    n_ok = sum(r.ok for r in results)
    off = [
        r
        for r in results
        if 'startup' not in r.quality
        and math.isfinite(r.drive_mismatch)
        and abs(r.drive_mismatch) > MISMATCH_LIMIT
    ]
    if off:
        worst = max(off, key=lambda r: abs(r.drive_mismatch))
        print(
            f'friction: warning: the drive speed of {len(off)} block(s) differs from the '
            f'RIG.yaml nominal_speed {nominal:.4g} rad/s by more than '
            f'{100 * MISMATCH_LIMIT:.0f} % (worst: block {worst.index}, {worst.w0:.4g} rad/s, '
            f'{100 * worst.drive_mismatch:+.1f} %); the measured drive speed is used '
            '(blocks.csv columns w0, drive_mismatch)',
            file=sys.stderr,
        )
    corrected = [
        r
        for r in results
        if math.isfinite(r.speed_offset)
        and math.isfinite(r.w0)
        and abs(r.speed_offset) > SPEED_CHANNEL_TOL * abs(r.w0)
    ]
    if corrected:
        med = float(np.median([r.speed_offset for r in corrected]))
        print(
            f'friction: warning: the speed channel reads {med:+.3g} rad/s off the drive speed '
            f'the stick lines show, in {len(corrected)} block(s) (a tachometer offset or gain '
            'error); the drive level of those blocks is taken from the stick lines '
            '(blocks.csv column speed_offset)',
            file=sys.stderr,
        )
    if not args.quiet:
        if jitter and max(jitter) >= 0.01:
            print(
                f'friction: time stamps jitter up to {max(jitter):.1%} of the sample interval: '
                'resampled onto the regular grid',
                file=sys.stderr,
            )
        if spikes.total:
            print(
                f'friction: {spikes.total} samples replaced (spikes, bursts; left out of the '
                'fits, blocks.csv columns spikes and bursts)',
                file=sys.stderr,
            )
        print(
            f'friction: {len(results)} blocks ({n_ok} ok) -> {out / "blocks.csv"} '
            f'in {time.monotonic() - t_wall:.1f} s',
            file=sys.stderr,
        )
    return 0


def _plots(out: Path, results: list[BlockResult], coll: _Collector, k: float) -> None:
    from tribo_estimation.core.blockfit import results_table
    from tribo_estimation.plots import plot_blocks, plot_detail, plot_mu_slip

    table = results_table(results)
    plot_blocks(table, out / 'blocks.png', title='friction per block')
    v, mu = coll.points()
    ks = np.array([r.k for r in results], dtype=float)
    plot_mu_slip(table, out / 'mu_slip.png', ks if ks.size else k, v, mu)
    traces = [coll.details[m] for m in ('stick-slip', 'slip-slip', 'steady') if m in coll.details]
    plot_detail(traces[:2], out / 'detail.png')
