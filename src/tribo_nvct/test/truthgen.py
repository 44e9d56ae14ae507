"""Independent truth generator for nVCT coverage checks (numpy/scipy only).

Shares no code with ``tribo_nvct``: the true depth profile is integrated
numerically on a 1 nm grid (the evaluation uses closed forms or its own fits),
the layer-removal data, the decay, background, dead time and Poisson counts are
written out here from the physics (paper 3.2-3.5, physics notes section 2):

    A_rem(z_i) = A_pin * integral_{z_i}^inf rho(s) ds * (1 + r eps_i)     [Bq]
    A_oil(t)   = A_I * integral_0^{h(t)} rho dz,  h(t) = V(t)/A_contact   [Bq, ref. date]
    n(t)       = A_oil(t) exp(-lambda (t_ref + t)) / k_DET + B             [1/s]
    counts     ~ Poisson(T m), m = n/(1 + n tau) (non-paralysable), live = T - counts tau

with V(t) = V_r (1 - exp(-t/tau_r)) + w t. The oil is taken as mixed at once
(no circuit): the coverage checks are about the profile and counting errors.
Used by ``bench/bench_nvct_coverage.py`` and the package's coverage test.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.special import erfc

FloatArray = NDArray[np.float64]

HALF_LIFE_CO56_D = 77.236
AREAL_ACTIVITY = 25e3 / 1e-6  # 25 kBq/mm^2 -> Bq/m^2
PIN_AREA_UM2 = 2.0e6
TAGGED_AREA_UM2 = 2.4e6
CONTACT_AREA_UM2 = 5.08e6
K_DET = 10.0
DEAD_TIME_S = 5e-6
DWELL_S = 60.0
N_DWELLS = 240
WINDOW_S = (120 * 60.0, 180 * 60.0)
SHAPES = ('flat_erfc', 'exponential', 'linear_ramp')


@dataclass(frozen=True)
class Case:
    """One generated test (units in the names; shape parameter p1, p2 in um)."""

    shape: str
    p1_um: float
    p2_um: float
    noise_rel: float
    step_um: float
    days: float
    background_cps: float
    running_in_um3: float
    tau_min: float
    rate_um3_per_min: float
    seed: int


def random_case(rng: np.random.Generator, seed: int, shape: str, noise_rel: float) -> Case:
    """Draw a test: profile parameters, step, days, background and true wear."""
    if shape == 'flat_erfc':
        p1, p2 = rng.uniform(1.5, 2.5), rng.uniform(0.4, 1.0)  # centre, width
    elif shape == 'exponential':
        p1, p2 = rng.uniform(0.8, 2.5), 0.0  # decay length
    elif shape == 'two_exponentials':
        p1, p2 = rng.uniform(0.3, 0.8), rng.uniform(2.0, 3.0)  # decay lengths
    else:
        p1, p2 = rng.uniform(2.5, 4.5), 0.0  # depth where the density reaches 0
    return Case(
        shape,
        float(p1),
        float(p2),
        noise_rel,
        float(rng.choice([0.05, 0.1, 0.15, 0.2, 0.25])),
        float(rng.uniform(0.0, 150.0)),
        float(rng.uniform(0.5, 5.0)),
        float(rng.uniform(1.5e5, 3.5e5)),
        float(rng.uniform(10.0, 25.0)),
        float(rng.uniform(600.0, 1400.0)),
        seed,
    )


def _shape(case: Case, z_um: FloatArray) -> FloatArray:
    if case.shape == 'flat_erfc':
        return np.asarray(0.5 * erfc((z_um - case.p1_um) / case.p2_um))
    if case.shape == 'exponential':
        return np.asarray(np.exp(-z_um / case.p1_um))
    if case.shape == 'two_exponentials':
        return np.asarray(0.6 * np.exp(-z_um / case.p1_um) + 0.4 * np.exp(-z_um / case.p2_um))
    return np.asarray(np.clip(1.0 - z_um / case.p1_um, 0.0, None))


class Truth:
    """True profile (numerically integrated) and wear of a :class:`Case`."""

    def __init__(self, case: Case) -> None:
        self.case = case
        zmax = 60.0
        self.z_um = np.linspace(0.0, zmax, int(zmax * 1000) + 1)  # 1 nm grid
        s = _shape(case, self.z_um)
        dz = np.diff(self.z_um) * 1e-6
        cum = np.concatenate([[0.0], np.cumsum(0.5 * (s[1:] + s[:-1]) * dz)])
        scale = AREAL_ACTIVITY / cum[-1]
        self.F = cum * scale  # Bq/m^2

    def F_at(self, h_um: FloatArray) -> FloatArray:
        """integral_0^h rho [Bq/m^2]."""
        return np.asarray(np.interp(h_um, self.z_um, self.F))

    def volume_um3(self, t_s: FloatArray) -> FloatArray:
        """True V_W(t) [um^3]."""
        c = self.case
        t = np.asarray(t_s, dtype=float)
        return np.asarray(
            c.running_in_um3 * -np.expm1(-t / (c.tau_min * 60.0)) + c.rate_um3_per_min * t / 60.0
        )

    def targets(self) -> dict[str, float]:
        """Total volume at the window end [um^3] and the window slope [um^3/min]."""
        t_mid = (np.arange(N_DWELLS, dtype=np.float64) + 0.5) * DWELL_S
        win = (t_mid >= WINDOW_S[0]) & (t_mid <= WINDOW_S[1])
        slope = np.polyfit(t_mid[win], self.volume_um3(t_mid[win]), 1)[0]
        return {
            'total_volume_um3': float(self.volume_um3(np.array(WINDOW_S[1]))),
            'progressive_rate_um3_per_min': float(slope * 60.0),
        }

    def write_layer_removal(self, path: Path, rng: np.random.Generator) -> None:
        """Layer-removal CSV of the reference pin to 5 um (noise r*A + 2 Bq, SE given)."""
        c = self.case
        z = np.round(np.arange(0.0, 5.0 + 1e-9, c.step_um), 9)
        a = PIN_AREA_UM2 * 1e-12 * (self.F[-1] - self.F_at(z))
        se = c.noise_rel * a + 2.0
        meas = a + se * rng.standard_normal(z.size)
        lines = ['depth_um,remaining_activity_bq,remaining_activity_se_bq']
        lines += [f'{zi:.4f},{ai:.6f},{si:.6f}' for zi, ai, si in zip(z, meas, se, strict=True)]
        path.write_text('\n'.join(lines) + '\n', encoding='utf-8')

    def dwells(self, rng: np.random.Generator) -> list[tuple[float, float, int, float]]:
        """(t_start, t_end, counts, live_time) of every dwell."""
        c = self.case
        lam = math.log(2.0) / (HALF_LIFE_CO56_D * 86400.0)
        t0 = c.days * 86400.0
        sub = 60
        out = []
        for i in range(N_DWELLS):
            ts = i * DWELL_S
            tt = ts + (np.arange(sub) + 0.5) * DWELL_S / sub  # midpoint rule
            h_um = self.volume_um3(tt) / CONTACT_AREA_UM2
            a_oil = TAGGED_AREA_UM2 * 1e-12 * self.F_at(h_um)
            n = float(np.mean(a_oil * np.exp(-lam * (t0 + tt)) / K_DET)) + c.background_cps
            m = n / (1.0 + n * DEAD_TIME_S)
            k = int(rng.poisson(m * DWELL_S))
            out.append((ts, ts + DWELL_S, k, DWELL_S - k * DEAD_TIME_S))
        return out

    def nvct_yaml(self, profile_csv: Path) -> dict[str, Any]:
        """The configuration an experimenter would write for this test."""
        c = self.case
        return {
            'nuclide': 'Co-56',
            'days_since_reference': c.days,
            'k_det': K_DET,
            'background_cps': c.background_cps,
            'depth_profile': str(profile_csv),
            'pin_area_um2': PIN_AREA_UM2,
            'tagged_area_um2': TAGGED_AREA_UM2,
            'contact_area_um2': CONTACT_AREA_UM2,
            'load_N': 100.0,
            'stroke_m': 0.0015,
            'frequency_hz': 50.0,
            'window_min': [WINDOW_S[0] / 60.0, WINDOW_S[1] / 60.0],
        }
