"""Hertz contact of the piston-ring section on the cylinder-liner section (paper 3.4, Fig. 9).

The ring is bent to a radius slightly smaller than the liner's, so the two
form a conformal contact (physics notes: k_A = contact area / tagged area
needs the contact area). Two cases:

* line contact: the ring's running face is straight in the axial direction; the
  ring (convex, radius R1) lies in the liner (concave, radius R2 > R1) along the
  ring height ``length``. Relative radius 1/R' = 1/R1 - 1/R2 and (Johnson,
  Contact Mechanics, 1985, eq. 4.43-4.45)
      b = sqrt(4 P R' / (pi L E*)),  p_max = 2 P / (pi b L),  area = 2 b L,
      p_mean = P / (2 b L) = (pi/4) p_max.

* elliptical contact: the running face is also crowned (barrel radius Rc) in
  the axial direction. Relative curvatures A = (1/R1 - 1/R2)/2 (circumferential)
  and B = 1/(2 Rc) (axial). With e the eccentricity of the contact ellipse
  (semi-axes a >= b, a along the lower curvature, m = e^2 = 1 - b^2/a^2) and
  K(m), E(m) the complete elliptic integrals (Johnson eq. 4.39-4.41):
      B/A = [(a/b)^2 E - K] / (K - E)                (solved for m)
      a^3 = 3 P (K - E) / (2 pi m A E*),  b = a sqrt(1 - m)
      p0 = 3 P / (2 pi a b),  p_mean = (2/3) p0,  area = pi a b.

E* is the contact modulus: 1/E* = (1-nu1^2)/E1 + (1-nu2^2)/E2.
All SI: N, m, Pa, m^2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from scipy.optimize import brentq
from scipy.special import ellipe, ellipkm1

from tribo_nvct.errors import ContactError


@dataclass(frozen=True)
class Material:
    """Elastic material: Young's modulus E [Pa], Poisson ratio nu [-]."""

    E: float
    nu: float

    def __post_init__(self) -> None:
        """Refuse a Young's modulus [Pa] that is not > 0 or a Poisson ratio outside (-1, 0.5)."""
        if not (math.isfinite(self.E) and self.E > 0.0):
            raise ContactError(f"Young's modulus must be > 0 Pa, got {self.E!r}")
        if not (math.isfinite(self.nu) and -1.0 < self.nu < 0.5):
            raise ContactError(f'Poisson ratio must be in (-1, 0.5), got {self.nu!r}')


def contact_modulus(m1: Material, m2: Material) -> float:
    """E* [Pa]: 1/E* = (1-nu1^2)/E1 + (1-nu2^2)/E2."""
    return 1.0 / ((1.0 - m1.nu**2) / m1.E + (1.0 - m2.nu**2) / m2.E)


@dataclass(frozen=True)
class ContactResult:
    """Hertz contact result (SI).

    kind: 'line' or 'elliptical'; load: P [N];
    half_width_circ: semi-axis along the circumference (ring/liner curvature) [m];
    half_width_axial: semi-axis along the liner axis [m] (half the ring height for line contact);
    area [m^2]; p_max, p_mean [Pa]; eccentricity e [-] (1 for line contact).
    """

    kind: str
    load: float
    half_width_circ: float
    half_width_axial: float
    area: float
    p_max: float
    p_mean: float
    eccentricity: float


def _check_pos(name: str, value: float) -> None:
    if not (math.isfinite(value) and value > 0.0):
        raise ContactError(f'{name} must be a positive finite number, got {value!r}')


def relative_radius(ring_radius: float, liner_radius: float) -> float:
    """R' [m] of a convex ring (R1) inside a concave liner (R2): 1/R' = 1/R1 - 1/R2."""
    _check_pos('ring radius', ring_radius)
    _check_pos('liner radius', liner_radius)
    if ring_radius >= liner_radius:
        raise ContactError(
            f'ring radius {ring_radius:g} m must be smaller than the liner radius '
            f'{liner_radius:g} m (conformal contact; otherwise the liner edges touch)'
        )
    return 1.0 / (1.0 / ring_radius - 1.0 / liner_radius)


def line_contact(load: float, R_rel: float, length: float, E_star: float) -> ContactResult:
    """Hertz line contact of length ``length`` [m] with relative radius R' [m]."""
    _check_pos('load', load)
    _check_pos('relative radius', R_rel)
    _check_pos('contact length', length)
    _check_pos('contact modulus', E_star)
    b = math.sqrt(4.0 * load * R_rel / (math.pi * length * E_star))
    p_max = 2.0 * load / (math.pi * b * length)
    area = 2.0 * b * length
    return ContactResult('line', load, b, 0.5 * length, area, p_max, load / area, 1.0)


def _curvature_ratio(p: float) -> float:
    """B/A as a function of p = 1 - m = (b/a)^2 (Johnson eq. 4.40)."""
    m = 1.0 - p
    K = float(ellipkm1(p))  # K(m) with full precision near m -> 1
    E = float(ellipe(m))
    return (E / p - K) / (K - E)


def ellipse_from_curvatures(load: float, A: float, B: float, E_star: float) -> ContactResult:
    """Hertz elliptical contact for relative curvatures A, B [1/m] (Johnson 4.39-4.41).

    Returns semi-axes assigned to the directions of A (``half_width_circ``) and
    B (``half_width_axial``). Solves B/A for the eccentricity with the complete
    elliptic integrals (no approximate formulas).
    """
    _check_pos('load', load)
    _check_pos('relative curvature A', A)
    _check_pos('relative curvature B', B)
    _check_pos('contact modulus', E_star)
    swap = A > B
    lo, hi = (B, A) if swap else (A, B)
    ratio = hi / lo
    if ratio - 1.0 < 1e-9:
        # Circle (Johnson 4.22): a^3 = 3 P R / (4 E*), 1/R = A + B.
        R = 1.0 / (lo + hi)
        a = (3.0 * load * R / (4.0 * E_star)) ** (1.0 / 3.0)
        b = a
        e = 0.0
    else:
        if ratio > 1e12:
            raise ContactError(
                f'curvature ratio {ratio:g} too large for an elliptical contact: use line contact'
            )
        lp = brentq(
            lambda x: _curvature_ratio(math.exp(x)) - ratio,
            math.log(1e-30),
            -1e-12,
            xtol=1e-14,
            rtol=1e-14,
            maxiter=500,
        )
        p = math.exp(lp)
        m = 1.0 - p
        K = float(ellipkm1(p))
        E = float(ellipe(m))
        a = (3.0 * load * (K - E) / (2.0 * math.pi * m * lo * E_star)) ** (1.0 / 3.0)
        b = a * math.sqrt(p)
        e = math.sqrt(m)
    p0 = 3.0 * load / (2.0 * math.pi * a * b)
    area = math.pi * a * b
    circ, axial = (b, a) if swap else (a, b)
    return ContactResult('elliptical', load, circ, axial, area, p0, load / area, e)


@dataclass(frozen=True)
class RingLinerGeometry:
    """Piston-ring section on cylinder-liner section (SI).

    ring_radius: bent ring outer radius R1 [m]; liner_radius: bore radius R2 > R1 [m];
    ring_height: axial width of the running face [m] (line-contact length);
    crown_radius: axial barrel radius of the running face [m], None/inf = straight
    (line contact); ring, liner: materials.
    """

    ring_radius: float
    liner_radius: float
    ring_height: float
    ring: Material
    liner: Material
    crown_radius: float | None = None

    def contact(self, load: float) -> ContactResult:
        """Hertz contact at normal load ``load`` [N]."""
        E_star = contact_modulus(self.ring, self.liner)
        R_rel = relative_radius(self.ring_radius, self.liner_radius)
        if self.crown_radius is None or math.isinf(self.crown_radius):
            return line_contact(load, R_rel, self.ring_height, E_star)
        _check_pos('crown radius', self.crown_radius)
        res = ellipse_from_curvatures(load, 0.5 / R_rel, 0.5 / self.crown_radius, E_star)
        if 2.0 * res.half_width_axial > self.ring_height:
            raise ContactError(
                f'elliptical contact {2e3 * res.half_width_axial:.3g} mm wide axially exceeds the '
                f'ring height {1e3 * self.ring_height:.3g} mm at {load:g} N: the face edge carries '
                'load, Hertz does not apply (use a larger crown radius or line contact)'
            )
        return res
