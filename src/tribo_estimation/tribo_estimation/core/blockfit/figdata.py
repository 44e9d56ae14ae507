"""Figure data of the block fit, kept while it streams (bounded memory, no matplotlib).

:class:`FigureData` keeps per block a few observer samples for the mu-versus-slip
figure and one detail window per motion type (paper Fig. 6, :class:`DetailTrace`);
:mod:`tribo_estimation.plots` draws them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from .results import BlockDetail, FloatArray

#: Observer samples kept per block for the mu-vs-slip-speed figure.
POINTS_PER_BLOCK = 60
#: Length of each detail window (Fig. 6) [s].
DETAIL_S = 0.15
#: Motion types in the order their detail windows are shown.
DETAIL_ORDER: tuple[str, ...] = ('stick-slip', 'slip-slip', 'steady')


def time_origin(t_first: float) -> float:
    """Return the origin [s] of a figure's time axis.

    0 for record time, the first block's start ``t_first`` [s] for wall-clock
    stamps (bags; anything after 1 Jan 1971).

    Parameters
    ----------
    t_first : float
        Start of the first block [s].

    Returns
    -------
    float
        The time subtracted on the figure's axis [s].
    """
    return float(t_first) if float(t_first) > 3.2e7 else 0.0


@dataclass(frozen=True, eq=False)
class DetailTrace:
    """Signals of one stretch of a run for a Fig. 6 style detail plot.

    Attributes
    ----------
    title
        panel title (e.g. "stick-slip, block at 12 s").
    time
        time [s].
    torsion
        measured torsion moment C1*phi1 [N m].
    moment
        observer friction moment M [N m] (NaN where unknown).
    simulated
        torsion moment simulated by the fit [N m] (NaN where not simulated).
    stick
        True where the discs stick.
    """

    title: str
    time: FloatArray
    torsion: FloatArray
    moment: FloatArray
    simulated: FloatArray
    stick: npt.NDArray[np.bool_]


@dataclass(eq=False)
class FigureData:
    """What the block fit's figures need, gathered block by block.

    Parameters
    ----------
    fnr : float
        ``F_N R`` of the rig [N m] (the friction moment over it is mu).

    Attributes
    ----------
    slip, mu : list of numpy.ndarray
        Slip speed |w2 - w1| [rad/s] and mu = |M| / (F_N R) [-] of up to
        :data:`POINTS_PER_BLOCK` sliding samples per block.
    details : dict of str to DetailTrace
        The first good block of each motion type (first :data:`DETAIL_S` s).
    origin : float or None
        Time origin of the figures [s] (:func:`time_origin` of the first block).
    """

    fnr: float
    slip: list[FloatArray] = field(default_factory=list)
    mu: list[FloatArray] = field(default_factory=list)
    details: dict[str, DetailTrace] = field(default_factory=dict)
    origin: float | None = None

    def add(self, det: BlockDetail) -> None:
        """Keep the figure data of one evaluated block.

        Parameters
        ----------
        det : BlockDetail
            The block's result and signals.
        """
        d = det.data
        res = det.result
        if self.origin is None:
            self.origin = time_origin(res.t_start)
        if d.moment.size == d.torsion.size and d.torsion.size:
            idx = np.flatnonzero(~d.stick)
            if idx.size:
                pick = idx[
                    np.linspace(0, idx.size - 1, min(POINTS_PER_BLOCK, idx.size)).astype(int)
                ]
                self.slip.append(np.abs(d.speed[pick] - d.chamber_speed[pick]))
                self.mu.append(np.abs(d.moment[pick]) / self.fnr)
        if res.ok and res.motion not in self.details:
            n = min(d.torsion.size, round(DETAIL_S * d.fs))
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

    def points(self) -> tuple[FloatArray, FloatArray]:
        """Return the kept slip speeds [rad/s] and friction coefficients [-].

        Returns
        -------
        tuple of numpy.ndarray
            Slip speeds and mu, concatenated over the blocks.
        """
        if not self.slip:
            return np.zeros(0), np.zeros(0)
        return np.concatenate(self.slip), np.concatenate(self.mu)

    def traces(self, most: int = 2) -> list[DetailTrace]:
        """Return up to ``most`` detail windows in :data:`DETAIL_ORDER`.

        Parameters
        ----------
        most : int
            Largest number of windows.

        Returns
        -------
        list of DetailTrace
            Stick-slip first, then slip-slip, then steady.
        """
        return [self.details[m] for m in DETAIL_ORDER if m in self.details][:most]
