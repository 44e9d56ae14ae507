"""Shapes of the depth-profile models: parametric densities and piecewise bases.

Depth in um inside the parametric shapes; R = integral_z^inf of the shape.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy.special import erfc

FloatArray = NDArray[np.float64]


def _ierfc(x: FloatArray) -> FloatArray:
    """ierfc(x) = integral_x^inf erfc(s) ds = exp(-x^2)/sqrt(pi) - x erfc(x), stable for x > 0."""
    from scipy.special import erfcx

    xp = np.clip(x, 0.0, None)
    pos = np.exp(-xp * xp) * (1.0 / math.sqrt(math.pi) - xp * erfcx(xp))
    xn = np.clip(x, None, 0.0)
    neg = np.exp(-xn * xn) / math.sqrt(math.pi) - xn * erfc(xn)
    return np.asarray(np.where(x > 0.0, pos, neg))


def _R(name: str, zu: FloatArray, th: FloatArray) -> FloatArray:
    """Remaining activity per unit amplitude of a parametric shape [um]."""
    name = name.removesuffix('+c')
    if name == 'erfc':
        z0, w = th
        return np.asarray(0.5 * w * _ierfc((zu - z0) / w))
    if name == 'exponential':
        (L,) = th
        return np.asarray(L * np.exp(-zu / L))
    (D,) = th
    d = np.clip(D - zu, 0.0, None)
    return np.asarray(d * d / (2.0 * D))


def _S(name: str, zu: FloatArray, th: FloatArray) -> FloatArray:
    """Density shape (value 1 at the top of the flat part) [-]."""
    name = name.removesuffix('+c')
    if name == 'erfc':
        z0, w = th
        return np.asarray(0.5 * erfc((zu - z0) / w))
    if name == 'exponential':
        (L,) = th
        return np.asarray(np.exp(-zu / L))
    (D,) = th
    return np.asarray(np.clip(1.0 - zu / D, 0.0, None))


def _bounds(name: str, Z: float, step: float) -> tuple[list[float], list[float]]:
    name = name.removesuffix('+c')
    if name == 'erfc':
        return [-2.0 * Z, max(0.05 * step, 1e-4)], [4.0 * Z, 4.0 * Z]
    if name == 'exponential':
        return [0.05 * step], [100.0 * Z]
    return [step], [100.0 * Z]


def _starts(name: str, Z: float) -> list[FloatArray]:
    name = name.removesuffix('+c')
    if name == 'erfc':
        return [np.array([a * Z, b * Z]) for a in (0.1, 0.3, 0.5, 0.8) for b in (0.05, 0.15, 0.4)]
    if name == 'exponential':
        return [np.array([a * Z]) for a in (0.1, 0.3, 1.0, 3.0)]
    return [np.array([a * Z]) for a in (0.5, 1.0, 1.5, 3.0)]


#: Parametric candidates; ``+c``: with a constant remaining activity c (bulk
#: activation below the layer, or a background offset of the pin measurements).
PARAMETRIC = ('erfc', 'exponential', 'ramp', 'erfc+c', 'exponential+c', 'ramp+c')


def _basis(kind: str, z: FloatArray, edges: FloatArray) -> tuple[FloatArray, FloatArray]:
    """(G, H): integral_0^z of the density basis [m] and its values [-] at depths z [m].

    ``piecewise``: indicator of each bin; ``linear``: hat functions on the edges
    (continuous piecewise-linear density).
    """
    if kind == 'piecewise':
        lo, hi = edges[:-1], edges[1:]
        G = np.clip(z[:, None], lo[None, :], hi[None, :]) - lo[None, :]
        j = np.clip(np.searchsorted(edges, z, side='right') - 1, 0, edges.size - 2)
        H = np.zeros((z.size, edges.size - 1))
        H[np.arange(z.size), j] = 1.0
        return G, H
    K = edges.size
    G = np.zeros((z.size, K))
    for k in range(K):
        c = edges[k]
        lo_k = edges[k - 1] if k > 0 else c
        hi_k = edges[k + 1] if k < K - 1 else c
        if c > lo_k:
            left = np.clip(z, lo_k, c) - lo_k
            G[:, k] += left * left / (2.0 * (c - lo_k))
        if hi_k > c:
            right = np.clip(z, c, hi_k) - c
            G[:, k] += right - right * right / (2.0 * (hi_k - c))
    eye = np.eye(K)
    H = np.column_stack([np.interp(z, edges, eye[k]) for k in range(K)])
    return G, H
