"""The Python API of tribo_estimation: rig config and record in, typed results out.

Every function reads through the package's one input stage
(:mod:`tribo_estimation.core.inputs`: units, time base, plausibility, spikes and
bursts) and returns a typed result (:mod:`tribo_estimation.results`) with
``rows()``, ``to_frame()``, ``write(dir)``, ``plot(dir)`` and ``summary()``. The
``tribo`` commands are thin shells over these functions. Bad input raises a
:class:`~tribo_estimation.errors.EstimationError` subclass whose message is the
line the CLI prints.

Examples
--------
>>> import tribo_estimation as te
>>> rig = te.load_rig('config/rig.yaml')  # doctest: +SKIP
>>> fit = te.fit_blocks(te.simulate(rig, 3.0, noise=True, seed=1), rig)  # doctest: +SKIP
>>> fit.summary()['blocks']  # doctest: +SKIP
3
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from tribo_estimation.core.record import RigRecord

if TYPE_CHECKING:
    from tribo_estimation.core.align import AlignEvent
    from tribo_estimation.core.blockfit import BlockResult
    from tribo_estimation.core.config import RigConfig
    from tribo_estimation.core.simulate import SimResult
    from tribo_estimation.results import BlockFit, DecayFit, MissingPhysics

PathLike = str | os.PathLike[str]
Progress = Callable[[str], None]


def load_rig(path: PathLike) -> RigConfig:
    """Read a RIG.yaml (``docs/ARCHITECTURE.md``, "RIG.yaml").

    Parameters
    ----------
    path : str or PathLike
        The file.

    Returns
    -------
    RigConfig
        Rig parameters (Tab. 1, SI), friction law (Equ. 8), drive profile,
        hidden model extensions and the noise levels.

    Raises
    ------
    ConfigFileError
        The file cannot be read or parsed.
    MissingKeyError, InvalidParameterError
        A key is missing or a value out of its range (each named).
    """
    from tribo_estimation.core.config import load_rig_config

    return load_rig_config(Path(path))


def _rig(rig: RigConfig | PathLike) -> RigConfig:
    if isinstance(rig, str | os.PathLike):
        return load_rig(rig)
    return rig


def read_record(
    path: PathLike,
    rig: RigConfig | PathLike | None = None,
    *,
    start: float = 0.0,
    duration: float = 0.0,
    namespace: str | None = None,
    keep_truncated: bool = False,
    progress: Progress | None = None,
) -> RigRecord:
    """Read a rig CSV or a bag through the input checks into one record.

    Parameters
    ----------
    path : str or PathLike
        Rig CSV (``time,torsion_moment,angular_acceleration,speed``, SI), bag
        directory or ``.mcap`` file with the ``rig/*`` SampleBlock streams.
    rig : RigConfig, str, PathLike or None
        The rig whose physics the channels are checked against (units, levels);
        None: only the time base and the spikes are checked.
    start : float
        Window start after the first sample [s].
    duration : float
        Window length [s] (0: to the end).
    namespace : str or None
        Rig namespace in a bag (default: its only rig).
    keep_truncated : bool
        A bag that ends early gives its good part (``findings.truncated``).
    progress : callable or None
        Receives a line per notable event (gaps, the stretch used).

    Returns
    -------
    RigRecord
        The longest gap-free stretch of the window; spikes and bursts replaced
        (``record.findings``).

    Raises
    ------
    InvalidDataError
        Bad input (unit, time base, unreadable value, speed at rest under a driven
        rig), naming the file, line or channel; ``RecordBagError`` for a missing
        file or a bag without rig streams; ``TooShortError`` for fewer than 100
        samples in the window.
    """
    from tribo_estimation.core import inputs

    return inputs.read_record(
        Path(path),
        _rig(rig) if rig is not None else None,
        start=start,
        duration=duration,
        namespace=namespace,
        keep_truncated=keep_truncated,
        progress=progress,
    )


def fit_blocks(
    source: RigRecord | PathLike,
    rig: RigConfig | PathLike,
    *,
    block_length: float = 1.0,
    fit_k: bool = False,
    check_drive_speed: bool = True,
    namespace: str | None = None,
    keep_truncated: bool = False,
    on_block: Callable[[BlockResult], None] | None = None,
) -> BlockFit:
    """Fit the friction law block by block (paper section 2.5, Equ. 8; ``tribo friction``).

    A path is streamed through the input checks (memory bounded by one block,
    whatever the session length, gaps never bridged); a record is fitted as it is.

    Parameters
    ----------
    source : RigRecord, str or PathLike
        A record, or a rig CSV or bag to stream.
    rig : RigConfig, str or PathLike
        The rig (Tab. 1 parameters, F_N, R, start values of the friction law).
    block_length : float
        Block length [s].
    fit_k : bool
        Also fit the Stribeck constant k [s/rad].
    check_drive_speed : bool
        Compare the measured drive speed with the config's nominal speed.
    namespace : str or None
        Rig namespace in a bag.
    keep_truncated : bool
        A bag that ends early gives the blocks before the damage (``truncated``
        names it) instead of raising.
    on_block : callable or None
        Called with each block's result as it is fitted (progress).

    Returns
    -------
    BlockFit
        One result per block (mu0, mu_inf, SE, motion type, quality).

    Raises
    ------
    InvalidDataError
        Bad input (as :func:`read_record`).
    TooShortError
        No complete block of data.
    """
    from tribo_estimation.core.blockfit import BlockConfig, BlockDetail, BlockEstimator
    from tribo_estimation.core.blockfit.figdata import FigureData
    from tribo_estimation.core.inputs import (
        CheckedInput,
        record_events,
        record_repairs,
        rig_scales,
    )
    from tribo_estimation.errors import TooShortError
    from tribo_estimation.results import BlockFit

    cfg_rig = _rig(rig)
    nominal = cfg_rig.drive.nominal_speed
    cfg = BlockConfig(
        block_length=block_length,
        fit_k=fit_k,
        nominal_speed=nominal if check_drive_speed and nominal > 0.0 else None,
        ramp_time=cfg_rig.drive.ramp_time,
    )
    stream: CheckedInput | None = None
    events: Iterator[AlignEvent]
    if isinstance(source, RigRecord):
        events = record_events(source)
        repairs = record_repairs(source)
        name = source.source
    else:
        stream = CheckedInput.open(Path(source), rig_scales(cfg_rig), namespace=namespace)
        events = iter(stream)
        repairs = stream.repairs
        name = stream.source
    fnr = cfg_rig.rig.F_N * cfg_rig.rig.R
    figures = FigureData(fnr if fnr > 0 else 1.0)
    est = BlockEstimator(cfg_rig.rig, cfg_rig.friction, cfg, repairs=repairs)
    results: list[BlockResult] = []

    def handle(dets: list[BlockDetail]) -> None:
        for det in dets:
            results.append(det.result)
            figures.add(det)
            if on_block is not None:
                on_block(det.result)

    for ev in events:
        handle(est.feed(ev))
    truncated = stream.truncated if stream is not None else None
    if truncated is None:
        handle(est.finish())  # the last block (a bag's damage cuts it: left out)
    elif not keep_truncated:
        raise truncated
    if not results:
        raise truncated or TooShortError(f'{name}: no complete block of data')
    if isinstance(source, RigRecord):
        f = source.findings
        warnings, replaced, jitter, cut = f.warnings, f.spikes, f.max_jitter, f.truncated
    else:
        assert stream is not None
        warnings, replaced, jitter = tuple(stream.warnings), stream.repairs.total, stream.max_jitter
        cut = str(truncated) if truncated is not None else ''
    return BlockFit(
        tuple(results),
        cfg,
        cfg_rig.friction.k,
        nominal,
        name,
        figures,
        tuple(warnings),
        replaced,
        jitter,
        cut,
    )


def find_missing_physics(
    records: RigRecord | PathLike | Sequence[RigRecord | PathLike],
    rig: RigConfig | PathLike,
    *,
    families: Sequence[str] | None = None,
    max_effects: int = 2,
    alpha: float = 0.01,
    time_budget: float | None = None,
    torsion_lag: bool = True,
    shared_friction: bool = False,
    progress: Progress | None = None,
) -> MissingPhysics:
    """Find the physics the rig model misses (docs/physics.md section 8; ``tribo discrepancy``).

    The paper's model (Equ. 1-8) is fitted with the record's instrument chain and
    drive profile; when it does not explain the record down to what noise leaves
    (its null law, measured on this record by a parametric bootstrap), every form
    of every candidate family is fitted; a family is named only when it alone
    explains the record, several that do are reported as a set the record cannot
    tell apart, with the experiment that would. Several records are fitted jointly
    (the effect shared).

    Parameters
    ----------
    records : RigRecord, str, PathLike or a sequence of them
        One record, or several fitted jointly; paths are read with :func:`read_record`.
    rig : RigConfig, str or PathLike
        The rig (mu0, mu_inf, k are fitted; its effects are not used).
    families : sequence of str or None
        Effect families to screen (None: the whole library).
    max_effects : int
        Most effects to add.
    alpha : float
        False-alarm rate of every adequacy decision [-] (a bound on the rate of
        naming an effect in a record with nothing missing).
    time_budget : float or None
        Wall time after which no further candidate form is fitted [s] (None: no limit);
        a family is then named only if every family was fitted.
    torsion_lag : bool
        Identify and compensate the torsion amplifier's (or accelerometer's) lag.
    shared_friction : bool
        Several records: one friction law for all (runs of one contact).
    progress : callable or None
        Receives the workflow's progress lines.

    Returns
    -------
    MissingPhysics
        The verdict, the named effects or the set, and per record what remains.

    Raises
    ------
    UnknownCandidateError
        A family name not in the library (names the known ones).
    InvalidDataError
        Bad input (as :func:`read_record`).
    """
    from dataclasses import replace

    from tribo_estimation.core.discrepancy import candidates as cand_lib
    from tribo_estimation.core.discrepancy.pipeline import Policy
    from tribo_estimation.core.discrepancy.pipeline import (
        find_missing_physics as run_pipeline,
    )

    cfg = _rig(rig)
    items = [records] if isinstance(records, RigRecord | str | os.PathLike) else list(records)
    recs = [r if isinstance(r, RigRecord) else read_record(r, cfg) for r in items]
    names = tuple(families) if families else None
    for n in names or ():
        cand_lib.forms(n)  # raises UnknownCandidateError naming the known families
    policy = Policy(
        alpha=alpha,
        families=names,
        max_effects=max_effects,
        torsion_lag=torsion_lag,
        time_budget=math.inf if time_budget is None else time_budget,
    )
    result = run_pipeline(
        recs,
        cfg.rig,
        [cfg.drive] * len(recs),
        k=cfg.friction.k,
        policy=policy,
        progress=progress,
        shared_friction=shared_friction,
    )
    return replace(
        result, inputs=tuple(r.findings for r in recs), sources=tuple(r.source for r in recs)
    )


def identify_decay(
    source: RigRecord | PathLike, *, t_start: float | None = None, t_end: float | None = None
) -> DecayFit:
    """Identify the chamber (I1, K1, C1) from a free decay (paper Equ. 7; ``tribo decay``).

    Parameters
    ----------
    source : RigRecord, str or PathLike
        A free-decay record, or the rig CSV or bag to read it from (checked
        against its own scales: there is no rig config yet).
    t_start, t_end : float or None
        Use ``t_start <= t <= t_end`` after the first sample [s].

    Returns
    -------
    DecayFit
        I1 [kg m^2], K1 [N m s/rad], C1 [N m/rad], f_n [Hz], zeta [-] with SE.

    Raises
    ------
    InvalidDataError
        Bad input (as :func:`read_record`).
    NoOscillationError, TooShortError
        The record shows no damped oscillation to identify.
    """
    from tribo_estimation.core.decay import identify_free_decay
    from tribo_estimation.results import DecayFit

    rec = source if isinstance(source, RigRecord) else read_record(source)
    res = identify_free_decay(
        rec.time - rec.time[0],
        rec.torsion_moment,
        rec.angular_acceleration,
        t_start=t_start,
        t_end=t_end,
    )
    return DecayFit(res, rec)


def simulate(
    rig: RigConfig | PathLike,
    duration: float,
    *,
    fs: float = 10_000.0,
    noise: bool = False,
    seed: int | None = None,
) -> SimResult:
    """Simulate the rig of a config (Equ. 1-3, 6, 8 and its hidden effects; ``tribo simulate``).

    Parameters
    ----------
    rig : RigConfig, str or PathLike
        The rig, friction law, drive and hidden extensions to simulate.
    duration : float
        Simulated time [s].
    fs : float
        Sample rate [Hz].
    noise : bool
        Add the config's measurement noise (``noise_*`` keys).
    seed : int or None
        Seed of the noise.

    Returns
    -------
    SimResult
        A record (``time``, ``torsion_moment``, ``angular_acceleration``,
        ``speed``) plus the truth (friction moment, slip speed, stick phases).

    Raises
    ------
    InvalidParameterError
        A duration or rate that gives no sample.
    """
    from tribo_estimation.core.simulate import simulate as run

    cfg = _rig(rig)
    return run(
        cfg.rig,
        cfg.friction,
        cfg.drive,
        duration,
        fs,
        extensions=cfg.extensions,
        noise=cfg.noise if noise else None,
        seed=seed,
    )


__all__ = [
    'find_missing_physics',
    'fit_blocks',
    'identify_decay',
    'load_rig',
    'read_record',
    'simulate',
]
