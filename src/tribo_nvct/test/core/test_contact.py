"""Hertz contact: closed-form and limiting cases, independent quadrature check."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from tribo_nvct.core.contact import (
    Material,
    RingLinerGeometry,
    contact_modulus,
    ellipse_from_curvatures,
    line_contact,
    relative_radius,
)
from tribo_nvct.errors import ContactError

STEEL = Material(2.1e11, 0.3)
IRON = Material(1.2e11, 0.26)
E_STAR = contact_modulus(STEEL, IRON)


def test_equal_curvatures_give_the_circle() -> None:
    R = 0.01
    res = ellipse_from_curvatures(100.0, 0.5 / R, 0.5 / R * (1 + 1e-12), E_STAR)
    a = (3.0 * 100.0 * R / (4.0 * E_STAR)) ** (1 / 3)  # ball R on a flat: A = B = 1/(2R)
    assert res.half_width_circ == pytest.approx(a, rel=1e-9)
    assert res.half_width_axial == pytest.approx(a, rel=1e-9)
    # Slightly different curvatures converge smoothly to the circle.
    near = ellipse_from_curvatures(100.0, 0.5 / R, 0.5 / R * 1.001, E_STAR)
    assert near.area == pytest.approx(res.area, rel=1e-3)
    assert near.half_width_circ > near.half_width_axial


def _ellipsoid_curvature(a: float, b: float, p0: float, along_a: bool) -> float:
    """Curvature coefficient of the gap (A or B) reproduced by an ellipsoidal pressure.

    Independent of the elliptic-integral algebra: the surface displacement under
    p0*sqrt(1 - x^2/a^2 - y^2/b^2) is quadratic with coefficients
    (p0 a b / (2 E*)) * int_0^inf dw / ((a^2+w or b^2+w) sqrt((a^2+w)(b^2+w) w)).
    """

    def f(w: float) -> float:
        d = math.sqrt((a * a + w) * (b * b + w) * w)
        return 1.0 / (((a * a) if along_a else (b * b)) + w) / d

    # Substitute w = s^2 to remove the 1/sqrt(w) singularity.
    val, _ = quad(lambda s: 2.0 * s * f(s * s), 0.0, np.inf, limit=500)
    return p0 * a * b / (2.0 * E_STAR) * val


@pytest.mark.parametrize('ratio', [1.5, 10.0, 300.0])
def test_ellipse_reproduces_curvatures_by_quadrature(ratio: float) -> None:
    A = 2.0
    B = A * ratio
    res = ellipse_from_curvatures(150.0, A, B, E_STAR)
    a, b = res.half_width_circ, res.half_width_axial  # a along A (smaller curvature)
    assert a > b
    assert _ellipsoid_curvature(a, b, res.p_max, True) == pytest.approx(A, rel=1e-6)
    assert _ellipsoid_curvature(a, b, res.p_max, False) == pytest.approx(B, rel=1e-6)
    # Load balance: integral of the ellipsoidal pressure = 2/3 pi a b p0.
    assert 2.0 / 3.0 * math.pi * a * b * res.p_max == pytest.approx(150.0, rel=1e-12)


def test_line_contact_closed_form_and_load_scaling() -> None:
    Rr = relative_radius(0.0415, 0.042)
    assert Rr == pytest.approx(0.0415 * 0.042 / 0.0005)
    r1 = line_contact(100.0, Rr, 1.2e-3, E_STAR)
    assert r1.half_width_circ == pytest.approx(
        math.sqrt(4 * 100 * Rr / (math.pi * 1.2e-3 * E_STAR))
    )
    # Equilibrium: semi-elliptical pressure integrates to the load.
    assert math.pi / 2 * r1.half_width_circ * r1.p_max * 1.2e-3 == pytest.approx(100.0)
    assert r1.p_mean == pytest.approx(math.pi / 4 * r1.p_max)
    r4 = line_contact(400.0, Rr, 1.2e-3, E_STAR)
    assert r4.half_width_circ == pytest.approx(2.0 * r1.half_width_circ)  # b ~ sqrt(P)


def test_slender_ellipse_tends_to_line_contact() -> None:
    # Very elongated ellipse: the central section carries q = (pi/2) b p0 per length
    # and must match the line-contact half-width for that q (2D limit).
    Rr = relative_radius(0.0415, 0.042)
    res = ellipse_from_curvatures(100.0, 0.5 / 1e4, 0.5 / Rr, E_STAR)
    b = res.half_width_axial
    q = math.pi / 2 * b * res.p_max
    b_line = math.sqrt(4 * q * Rr / (math.pi * E_STAR))
    # The 2D limit holds up to O((b/a)^2 ln(a/b)) terms: 2 % here.
    assert b == pytest.approx(b_line, rel=0.02)


def test_fig9_loads_and_bad_geometry() -> None:
    g = RingLinerGeometry(0.0415, 0.042, 1.2e-3, STEEL, IRON)
    areas = [g.contact(P).area for P in (50.0, 100.0, 150.0, 200.0)]
    assert np.all(np.diff(areas) > 0)
    assert areas[3] / areas[0] == pytest.approx(2.0)  # area ~ sqrt(P) for line contact
    with pytest.raises(ContactError, match='smaller than the liner'):
        RingLinerGeometry(0.043, 0.042, 1.2e-3, STEEL, IRON).contact(100.0)
    with pytest.raises(ContactError, match='exceeds the ring height'):
        RingLinerGeometry(0.0415, 0.042, 1.2e-3, STEEL, IRON, crown_radius=5.0).contact(200.0)
    with pytest.raises(ContactError):
        Material(-1.0, 0.3)
