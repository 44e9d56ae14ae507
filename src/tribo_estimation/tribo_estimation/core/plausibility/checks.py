"""Units and time base of a rig record against the rig's physics (no rclpy).

See :mod:`tribo_estimation.core.plausibility` for the criteria.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from tribo_estimation.core.plausibility.scales import Scales, amplitude
from tribo_estimation.core.plausibility.spikes import GROSS_FACTOR, find_spikes
from tribo_estimation.errors import TimeBaseError, UnitError

FloatArray = npt.NDArray[np.float64]

#: Sample rates a rig record may have [Hz] (DAQ range of the rig).
FS_MIN = 100.0
FS_MAX = 100_000.0
#: Largest ratio between a channel's robust amplitude and its physical scale
#: before the channel is taken as written in other units.
UNIT_RATIO = 30.0
#: Acceleration may exceed its physical bound (|C1 phi1| + F_N R mu)/I1 by this
#: factor (noise) before it is taken as written in other units (deg/s^2: x57.3).
ACCEL_RATIO = 4.0
#: Relative difference of the speed channel's median from nominal_speed that
#: is reported (warning) [-].
SPEED_WARN = 0.05


def check_time_base(fs: float, source: str, f_stick_slip: float | None = None) -> None:
    """Refuse a sample rate [Hz] that the rig cannot have.

    Outside 0.1-100 kHz (naming the likely time unit) or too slow for the
    stick-slip frequency ``f_stick_slip`` [Hz].
    """
    if not math.isfinite(fs) or fs <= 0.0:
        raise TimeBaseError(f'{source}: time column gives no sample rate ({fs} Hz)')
    if fs < FS_MIN:
        hint = ''
        if FS_MIN <= fs * 1e3 <= FS_MAX:
            hint = f'; the time column looks like ms (that would be {fs * 1e3:g} Hz): convert to s'
        raise TimeBaseError(
            f'{source}: sample rate {fs:.4g} Hz is below the rig DAQ range '
            f'{FS_MIN:g}-{FS_MAX:g} Hz{hint}'
        )
    if fs > FS_MAX:
        hint = ''
        for unit, f in (('us', 1e-6), ('ns', 1e-9)):
            if FS_MIN <= fs * f <= FS_MAX:
                hint = f'; the time column looks like {unit}: convert to s'
                break
        raise TimeBaseError(
            f'{source}: sample rate {fs:.4g} Hz is above the rig DAQ range '
            f'{FS_MIN:g}-{FS_MAX:g} Hz{hint}'
        )
    if f_stick_slip is not None and fs < 4.0 * f_stick_slip:
        raise TimeBaseError(
            f'{source}: sample rate {fs:.4g} Hz is too slow for the stick-slip frequency '
            f'sqrt(C1/I1)/2pi = {f_stick_slip:.4g} Hz (need >= 4x)'
        )


def _clean(x: FloatArray, scale: float) -> FloatArray:
    """Finite, non-spike samples of ``x`` (for robust statistics)."""
    m = find_spikes(x, scale) if scale > 0 else ~np.isfinite(x)
    return x[~m]


def check_channels(
    torque: FloatArray,
    accel: FloatArray,
    speed: FloatArray,
    scales: Scales,
    source: str,
    whole_record: bool = True,
) -> list[str]:
    """Compare each channel with the rig's physical scales.

    Returns warnings (one line each); raises :class:`UnitError` for a likely unit
    mistake or, when the channels are the ``whole_record``, a speed channel at rest
    under a driven RIG.yaml (for the start of a stream that is a warning: the drive
    may start later).
    """
    warnings: list[str] = []
    tq = _clean(torque, scales.torque)
    if scales.torque > 0 and tq.size:
        med = float(np.median(np.abs(tq)))
        amp = amplitude(tq)
        if amp > UNIT_RATIO * scales.torque:
            ratio = amp / scales.torque
            hint = ' looks like N mm' if 300.0 <= ratio <= 3000.0 else ' is far too large'
            raise UnitError(
                f'{source}: torsion_moment{hint}: median {med:.3g}, expected about '
                f'{scales.torque:.3g} N m (F_N R mu of the rig config)'
            )
    if scales.torque > 0 and scales.accel > 0:
        # |w1'| <= (|C1 phi1| + F_N R mu) / I1 (Equ. 1); I1 = torque / accel scale
        per_nm = scales.accel / scales.torque  # 1 / I1 [1/(kg m^2)]
        expected = (max(amplitude(tq) if tq.size else 0.0, 0.0) + scales.torque) * per_nm
        amp_a = amplitude(_clean(accel, GROSS_FACTOR * expected))
        if amp_a > ACCEL_RATIO * expected:
            raise UnitError(
                f'{source}: angular_acceleration exceeds what the torque can cause: 95th '
                f'percentile {amp_a:.3g}, at most about {expected:.3g} rad/s^2 '
                '((|C1 phi1| + F_N R mu) / I1); deg/s^2 instead of rad/s^2 (x57.3)?'
            )
    # the second half: past the drive's start-up ramp
    sp = _clean(speed[speed.shape[0] // 2 :], max(scales.speed, 1.0))
    if scales.speed > 0 and sp.size:
        med = float(np.median(np.abs(sp)))
        ratio = med / scales.speed
        if abs(ratio - 30.0 / math.pi) < 0.15 * 30.0 / math.pi:
            raise UnitError(
                f'{source}: speed looks like rpm: median {med:.4g}, expected about '
                f'{scales.speed:.4g} rad/s (nominal_speed); convert: rad/s = rpm*pi/30'
            )
        if ratio < SPEED_WARN:
            msg = (
                f'{source}: speed channel is at rest (median {med:.3g} rad/s) but the rig '
                f'config drives at {scales.speed:.4g} rad/s: a free-decay record? '
                '(use `tribo decay`)'
            )
            if whole_record:
                raise UnitError(msg)
            warnings.append(msg.replace('is at rest', 'is at rest at the start'))
        # a drive speed other than nominal_speed is not checked here: the fits measure
        # the drive profile and warn about it once (core.drive, drive_mismatch)
    return warnings
