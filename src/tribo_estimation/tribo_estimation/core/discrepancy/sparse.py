"""SINDy-style sparse regression of a residual on a library of candidate terms.

When the named candidates leave structure in the torsion-moment residual, the
workflow proposes a data-driven term: the residual r (N m) is regressed on a
library of features (constant, test time, slip speed, its sign, the stick
indicator, sinusoids at the remaining spectral lines, harmonics of the shaft
angle, ...) by sequentially thresholded least squares (STLSQ, Brunton et al.
2016): fit, zero the coefficients whose contribution is below a threshold,
refit on the survivors, repeat. The proposal is a hint for the engineer, not
part of the fitted model.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .stats import FloatArray


@dataclass(frozen=True)
class SparseTerm:
    """One selected term: ``coefficient * feature`` (residual unit, N m for torque)."""

    name: str
    coefficient: float


@dataclass(frozen=True)
class SparseModel:
    """Result of :func:`stlsq`: selected terms and the residual rms before/after."""

    terms: tuple[SparseTerm, ...]
    rms_before: float
    rms_after: float


def stlsq(
    features: dict[str, FloatArray],
    target: FloatArray,
    *,
    threshold: float,
    max_iter: int = 10,
    max_terms: int = 4,
) -> SparseModel:
    """Sequentially thresholded least squares.

    A term survives if the rms of its contribution ``coef*feature`` is at least
    ``threshold`` (in the target's unit). At most ``max_terms`` of the largest
    contributions are kept. Non-finite samples (any feature or the target) are
    skipped.
    """
    names = list(features)
    y = np.asarray(target, dtype=np.float64)
    if not names:
        r = float(np.sqrt(np.mean(y * y))) if y.size else float('nan')
        return SparseModel((), r, r)
    X = np.column_stack([np.asarray(features[n], dtype=np.float64) for n in names])
    ok = np.isfinite(y) & np.all(np.isfinite(X), axis=1)
    X, y = X[ok], y[ok]
    rms_before = float(np.sqrt(np.mean(y * y))) if y.size else float('nan')
    if y.size < X.shape[1] + 2:
        return SparseModel((), rms_before, rms_before)
    col_rms = np.sqrt(np.mean(X * X, axis=0))
    usable = col_rms > 0
    active = usable.copy()
    coef = np.zeros(X.shape[1])
    for _ in range(max_iter):
        coef = np.zeros(X.shape[1])
        if not np.any(active):
            break
        sol, *_ = np.linalg.lstsq(X[:, active], y, rcond=None)
        coef[active] = sol
        contrib = np.abs(coef) * col_rms
        new_active = active & (contrib >= threshold)
        if np.count_nonzero(new_active) > max_terms:
            keep = np.argsort(-np.where(new_active, contrib, -1.0))[:max_terms]
            mask = np.zeros_like(new_active)
            mask[keep] = True
            new_active = new_active & mask
        if np.array_equal(new_active, active):
            break
        active = new_active
    if np.any(active):
        sol, *_ = np.linalg.lstsq(X[:, active], y, rcond=None)
        coef = np.zeros(X.shape[1])
        coef[active] = sol
    resid = y - np.sum(X * coef, axis=1)
    terms = tuple(
        SparseTerm(names[i], float(coef[i]))
        for i in np.argsort(-np.abs(coef) * col_rms)
        if active[i] and coef[i] != 0.0
    )
    return SparseModel(terms, rms_before, float(np.sqrt(np.mean(resid * resid))))


def feature_library(
    *,
    time: FloatArray,
    slip_speed: FloatArray,
    stick: FloatArray,
    shaft_angle: FloatArray,
    chamber_speed: FloatArray,
    line_frequencies: tuple[float, ...] = (),
    include_angle: bool = True,
) -> dict[str, FloatArray]:
    """Build the default term library (names say what each feature is, SI units).

    ``time`` s, ``slip_speed`` rad/s (simulated), ``stick`` 0/1,
    ``shaft_angle`` rad, ``chamber_speed`` rad/s, ``line_frequencies`` Hz;
    ``include_angle`` adds shaft-angle harmonics (only meaningful when the
    record covers several revolutions, else they mimic a trend).
    """
    t = np.asarray(time, dtype=np.float64)
    v = np.asarray(slip_speed, dtype=np.float64)
    th = np.asarray(shaft_angle, dtype=np.float64)
    tc = t - t[0]
    lib: dict[str, FloatArray] = {
        't': tc,
        'v': v,
        'sgn(v)': np.sign(v),
        'stick': np.asarray(stick, dtype=np.float64),
        'sgn(w1)': np.sign(np.asarray(chamber_speed, dtype=np.float64)),
    }
    if include_angle:
        lib['cos(theta2)'] = np.cos(th)
        lib['sin(theta2)'] = np.sin(th)
        lib['cos(2*theta2)'] = np.cos(2 * th)
        lib['sin(2*theta2)'] = np.sin(2 * th)
    for f in line_frequencies:
        lib[f'cos(2*pi*{f:.3f}*t)'] = np.cos(2 * np.pi * f * t)
        lib[f'sin(2*pi*{f:.3f}*t)'] = np.sin(2 * np.pi * f * t)
    # centred features, so that '1' carries the mean and no pair of large,
    # nearly collinear columns cancels each other
    out: dict[str, FloatArray] = {'1': np.ones_like(t)}
    for name, col in lib.items():
        ok = np.isfinite(col)
        out[name] = col - (float(np.mean(col[ok])) if np.any(ok) else 0.0)
    return out
