"""Records of the independent scenario generator (validation/tribo_scenarios) for the tests.

The generator shares no code with the fits. A test asks for a controlled record: the
paper's Tab. 1 rig, a clean instrument chain (white noise at config/rig.yaml's
levels, no gains, offsets or lags) unless it asks for more, a drive profile of its
choice and one hidden effect in a given form.
"""

from __future__ import annotations

import dataclasses
import math

from tribo_scenarios import generate
from tribo_scenarios.spec import (
    ChannelSpec,
    DriveSpec,
    EffectSpec,
    InstrumentSpec,
    RigTruth,
    ScenarioSpec,
    Transition,
)

from tribo_estimation.core.model import DriveProfile, RigParams
from tribo_estimation.core.record import RigRecord

TAB1 = RigTruth(0.0109, 0.04034, 2338.6, 0.0315, 4.0, 5975.0, 8000.0, 0.08, 0.13, 0.10, 2.0)
NOISE = (0.05, 2.0, 0.005)


def rpm(x: float) -> float:
    """Return x rpm in rad/s."""
    return x * math.pi / 30.0


def clean_instrument(scale: float = 1.0) -> InstrumentSpec:
    """Return white noise at config/rig.yaml's levels times ``scale`` on every channel."""
    t, a, s = NOISE
    return InstrumentSpec(
        ChannelSpec(1.0, 0.0, 0, 0.0, 0.0, scale * t),
        ChannelSpec(1.0, 0.0, 0, 0.0, 0.0, scale * a),
        ChannelSpec(1.0, 0.0, 0, 0.0, 0.0, scale * s),
    )


def constant(speed: float, start: float = 1.5) -> DriveSpec:
    """Return a drive at ``speed`` [rad/s] whose record starts ``start`` s after its ramp."""
    return DriveSpec(
        'constant', (Transition(0.0, 0.3, speed, 'linear'),), start, speed, None, ('warm',)
    )


def step(
    speed: float,
    to: float,
    at: float,
    start: float = 1.5,
    shape: str = 'linear',
    length: float = 0.05,
) -> DriveSpec:
    """Return a drive at ``speed`` stepping to ``to`` [rad/s] ``at`` s into the record.

    ``shape`` of the transition: 'linear' or 'cosine' (raised cosine); ``length`` its
    duration [s].
    """
    moves = (
        Transition(0.0, 0.3, speed, 'linear'),
        Transition(start + at, length, to - speed, shape),
    )
    return DriveSpec('steps', moves, start, speed, None, ('warm', 'step'))


def sweep(speed: float, to: float, begin: float, length: float, start: float = 1.5) -> DriveSpec:
    """Return a linear sweep from ``speed`` to ``to`` [rad/s] over ``length`` s."""
    moves = (
        Transition(0.0, 0.3, speed, 'linear'),
        Transition(start + begin, length, to - speed, 'linear'),
    )
    return DriveSpec('sweep', moves, start, speed, None, ('warm', 'sweep'))


def record(
    seed: int,
    drive: DriveSpec,
    *,
    duration: float = 3.0,
    effect: EffectSpec | None = None,
    instrument: InstrumentSpec | None = None,
    fs: float = 10_000.0,
    rig: RigTruth = TAB1,
) -> tuple[RigRecord, RigParams, DriveProfile]:
    """Simulate one controlled record (Tab. 1 rig) and return it with the user's config.

    Parameters
    ----------
    seed : int
        Seed of the noise.
    drive : DriveSpec
        The drive profile.
    duration : float
        Record length [s].
    effect : EffectSpec or None
        The hidden effect (None: nothing hidden).
    instrument : InstrumentSpec or None
        The instrument chain (None: :func:`clean_instrument`).
    fs : float
        Sample rate [Hz].
    rig : RigTruth
        The rig and its friction (default: Tab. 1); the user's config is exact.

    Returns
    -------
    tuple
        The record, the rig and the drive a user would configure.
    """
    r = rig
    spec = ScenarioSpec(
        seed=seed,
        duration=duration,
        fs=fs,
        rig=r,
        drive=drive,
        instrument=instrument or clean_instrument(),
        effect=effect or EffectSpec('none', 'none', 'none'),
        user_rig={f.name: getattr(r, f.name) for f in dataclasses.fields(r)}
        | {'nominal_speed': drive.nominal_speed},
        labels={},
    )
    sc = generate(spec, use_cache=False)
    rec = RigRecord(sc.time, sc.torsion_moment, sc.angular_acceleration, sc.speed, fs=sc.fs)
    rig = RigParams(r.I1, r.K1, r.C1, r.I2, r.K2, r.C2, r.F_N, r.R)
    return rec, rig, DriveProfile(drive.nominal_speed, 0.0)
