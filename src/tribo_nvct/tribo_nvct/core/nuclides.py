"""Radionuclides used for thin-layer activation (TLA/PTLA) wear measurement.

Half-lives: ENSDF evaluated values as listed by NNDC NuDat 3
(https://www.nndc.bnl.gov/nudat3/, checked against the DDEP/LNHB
"Recommended data" tables, http://www.lnhb.fr/nuclear-data/nuclear-data-table/).
Exemption activities: Council Directive 2013/59/Euratom, Annex VII, Table B
(identical to IAEA GSR Part 3, Schedule I, Table I.1) -- the "free limit"
the paper's nVCT specimens stay below (paper 3.2). Check your national
regulation before relying on them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from tribo_nvct.errors import NvctConfigError, UnknownNuclideError

SECONDS_PER_DAY = 86_400.0


@dataclass(frozen=True)
class Nuclide:
    """A radionuclide: half-life [d] and exemption activity [Bq] (NaN if unknown)."""

    name: str
    half_life_days: float
    exemption_bq: float = math.nan

    @property
    def half_life_s(self) -> float:
        """Half-life [s]."""
        return self.half_life_days * SECONDS_PER_DAY

    @property
    def decay_constant(self) -> float:
        """Decay constant lambda = ln 2 / T_half [1/s]."""
        return math.log(2.0) / self.half_life_s


#: name -> Nuclide. Half-life uncertainties (last digits) in the comments.
NUCLIDES: dict[str, Nuclide] = {
    # Fe-56(p,n)Co-56: the usual TLA label of steel and cast iron.
    'Co-56': Nuclide('Co-56', 77.236, 1e5),  # 77.236(26) d
    # Fe-57(p,n)Co-57 / Ni(p,x): long-lived label.
    'Co-57': Nuclide('Co-57', 271.74, 1e6),  # 271.74(6) d
    # Ni-58(n,p) / Fe(d,x)Co-58.
    'Co-58': Nuclide('Co-58', 70.86, 1e6),  # 70.86(6) d
    # Fe-58(n,g)Fe-59.
    'Fe-59': Nuclide('Fe-59', 44.495, 1e6),  # 44.495(9) d
    # V(p,n)Cr-51 / Cr-50(n,g): chromium coatings.
    'Cr-51': Nuclide('Cr-51', 27.7025, 1e7),  # 27.7025(24) d
    # Li/B(p,x)Be-7 or recoil implantation: polymers, ceramics.
    'Be-7': Nuclide('Be-7', 53.22, 1e7),  # 53.22(6) d
    # Cu-65(p,n)Zn-65: bronzes, brass.
    'Zn-65': Nuclide('Zn-65', 243.93, 1e6),  # 243.93(9) d
    # Ti-48(p,n)V-48: titanium alloys, TiN coatings.
    'V-48': Nuclide('V-48', 15.9735, 1e5),  # 15.9735(25) d
    # Fe-56(d,a)Mn-54.
    'Mn-54': Nuclide('Mn-54', 312.20, 1e6),  # 312.20(20) d
}


def _normalise(name: str) -> str:
    text = name.strip().replace('_', '-').replace(' ', '-')
    # Accept "co56", "Co56", "56Co", "CO-56".
    letters = ''.join(c for c in text if c.isalpha())
    digits = ''.join(c for c in text if c.isdigit())
    if not letters or not digits:
        return text
    return f'{letters[0].upper()}{letters[1:].lower()}-{digits}'


def get_nuclide(name: str) -> Nuclide:
    """Look a nuclide up by name (``Co-56``, ``co56``, ``56Co`` ...)."""
    key = _normalise(name)
    try:
        return NUCLIDES[key]
    except KeyError:
        known = ', '.join(sorted(NUCLIDES))
        raise UnknownNuclideError(
            f'unknown nuclide {name!r} (known: {known}); give half_life_days instead'
        ) from None


def custom_nuclide(half_life_days: float, name: str = 'custom') -> Nuclide:
    """Make a nuclide given only by its half-life [d] (> 0)."""
    if not (math.isfinite(half_life_days) and half_life_days > 0.0):
        raise NvctConfigError(f'half_life_days must be a positive number, got {half_life_days!r}')
    return Nuclide(name, float(half_life_days))
