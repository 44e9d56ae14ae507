"""Result types of the stick detector: stick phases and the per-record report."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

MOTION_TYPES: tuple[str, ...] = ('stick-slip', 'slip-slip', 'steady')

#: Shortest stick phase counted as a stick [s] (10 samples at 10 kHz); shorter
#: detected phases are micro-sticks (counted apart).
MIN_STICK = 1e-3


@dataclass(frozen=True)
class StickPhase:
    """One stick phase: ``start``, ``end`` [s] and ``duration`` = end - start [s].

    ``drive_speed`` [rad/s]: the drive speed w0 its stick line shows at its middle
    (the stick residual rises as ``C2*w0``, Equ. 1 + 2 with w1 = w2; free of the speed
    channel); NaN for a phase of fewer than 6 samples. Not part of equality.
    """

    start: float
    end: float
    drive_speed: float = field(default=math.nan, compare=False)

    @property
    def duration(self) -> float:
        """Duration end - start [s]."""
        return self.end - self.start


@dataclass(frozen=True)
class StickReport:
    """Result of :func:`find_sticks` for one record or block.

    ``sticks``: phases of at least ``min_duration`` [s]; ``micro``: shorter detected
    phases (micro-sticks); ``motion``: ``'stick-slip'`` whenever ``sticks`` is not
    empty, else ``'slip-slip'`` or ``'steady'`` (:func:`classify_motion`);
    ``drive_speed``: mean drive-speed level [rad/s] used by the candidate stage;
    ``min_duration`` [s]; ``torsion_lag``: torsion-amplifier lag compensated [s]
    (given or estimated by :func:`estimate_torsion_lag`).
    """

    sticks: tuple[StickPhase, ...]
    micro: tuple[StickPhase, ...]
    motion: str
    drive_speed: float
    min_duration: float
    torsion_lag: float = 0.0

    @property
    def n_sticks(self) -> int:
        """Number of sticks (phases of at least ``min_duration``)."""
        return len(self.sticks)

    @property
    def n_micro(self) -> int:
        """Number of micro-sticks (shorter detected phases)."""
        return len(self.micro)

    def count_starting_after(self, t: float) -> int:
        """Count the sticks (>= min_duration) that start after ``t`` [s].

        Per-block counts: a stick running at a block start belongs to the block
        before.

        Parameters
        ----------
        t : float
            Time [s].

        Returns
        -------
        int
            The number of sticks.
        """
        return sum(1 for p in self.sticks if p.start > t)
