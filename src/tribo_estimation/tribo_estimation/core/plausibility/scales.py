"""Physical scales of the rig's channels, from the rig or from a record (no rclpy)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from tribo_estimation.core.model import FrictionLaw, RigParams
from tribo_estimation.errors import UnitError

FloatArray = npt.NDArray[np.float64]


#: No channel of the rig measures a magnitude beyond this (SI units) [-].
ABSURD = 1e30


@dataclass(frozen=True)
class Scales:
    """Physical scales of the rig's channels (SI).

    Attributes
    ----------
    torque
        friction moment ``F_N R mu`` with the larger mu of RIG.yaml [N m].
    accel
        ``torque / I1`` [rad/s^2].
    speed
        ``|nominal_speed|`` [rad/s] (0: drive at rest).
    f_stick_slip
        natural frequency of the chamber ``sqrt(C1/I1)/(2 pi)`` [Hz].
    from_record
        True when the scales are the record's own medians (no rig config,
        :meth:`from_data`): not physical bounds, so a burst must also stand out
        of the record's own amplitude (:func:`despike_chunk`).
    """

    torque: float
    accel: float
    speed: float
    f_stick_slip: float
    from_record: bool = False

    @classmethod
    def of(cls, rig: RigParams, friction: FrictionLaw, nominal_speed: float) -> Scales:
        """Take the scales from the rig config.

        Parameters
        ----------
        rig : RigParams
            Rig parameters (F_N [N], R [m], I1 [kg m^2], C1 [N m/rad]).
        friction : FrictionLaw
            Friction law of the config (the larger of mu0, mu_inf counts).
        nominal_speed : float
            Drive speed of the config [rad/s].

        Returns
        -------
        Scales
            The physical scales of the channels.
        """
        mu = max(friction.mu0, friction.mu_inf, 0.01)
        torque = rig.F_N * rig.R * mu
        return cls(
            torque=torque,
            accel=torque / rig.I1,
            speed=abs(nominal_speed),
            f_stick_slip=math.sqrt(rig.C1 / rig.I1) / (2.0 * math.pi),
        )

    @classmethod
    def from_data(
        cls, torque: FloatArray, accel: FloatArray, speed: FloatArray, source: str = 'record'
    ) -> Scales:
        """Take the scales from the record itself.

        Median of each |channel| (robust to bursts of up to half the record), for a
        record without a rig config (free decay); ``f_stick_slip`` is NaN.

        Parameters
        ----------
        torque, accel, speed : numpy.ndarray
            Torsion moment [N m], chamber acceleration [rad/s^2], shaft speed [rad/s].
        source : str
            Name of the record for messages.

        Returns
        -------
        Scales
            The record's own scales (``from_record`` True).

        Raises
        ------
        UnitError
            A channel's median is beyond :data:`ABSURD` (no rig measures that:
            most of the channel is garbage).
        """

        def amp(x: FloatArray, name: str) -> float:
            a = np.abs(x[np.isfinite(x)])
            with np.errstate(over='ignore', invalid='ignore'):  # median of two 1e308
                med = float(np.median(a)) if a.size else 0.0
            if med > ABSURD:
                raise UnitError(
                    f'{source}: {name} is not a measurement: median |value| {med:.3g} '
                    f'(most samples beyond {ABSURD:g})'
                )
            return med

        return cls(
            amp(torque, 'torsion_moment'),
            amp(accel, 'angular_acceleration'),
            amp(speed, 'speed'),
            math.nan,
            True,
        )


def amplitude(x: FloatArray) -> float:
    """Return the robust amplitude of ``x``: the 95th percentile of |x| [unit of x]."""
    return float(np.percentile(np.abs(x), 95.0)) if x.size else 0.0
