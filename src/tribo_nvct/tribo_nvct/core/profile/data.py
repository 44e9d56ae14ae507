"""Layer-removal data of a reference pin: reading, checks and the noise model."""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import nnls

from tribo_nvct.errors import DepthProfileError, ProfileNotDecreasingError

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class LayerRemovalData:
    """Raw layer-removal measurements of a reference pin.

    depth_m: removed depth z_i [m], strictly increasing, first 0.
    remaining_bq: activity left in the pin after removal to z_i [Bq].
    remaining_se_bq: its standard error [Bq], or None (then estimated from the fit).
    source: file name for messages.
    """

    depth_m: FloatArray
    remaining_bq: FloatArray
    remaining_se_bq: FloatArray | None = None
    source: str = '<data>'

    def __post_init__(self) -> None:
        """Check the rows (at least 4, finite, depth from 0 increasing, SE > 0)."""
        z, a = self.depth_m, self.remaining_bq
        src = self.source
        if z.ndim != 1 or a.shape != z.shape or z.size < 4:
            raise DepthProfileError(f'{src}: need >= 4 rows of depth and remaining activity')
        if not (np.all(np.isfinite(z)) and np.all(np.isfinite(a))):
            raise DepthProfileError(f'{src}: depth or remaining activity is not finite (NaN/inf)')
        if abs(z[0]) > 1e-12:
            raise DepthProfileError(
                f'{src}: first depth must be 0 (the unworn surface), got {z[0] * 1e6:g} um'
            )
        dz = np.diff(z)
        if np.any(dz <= 0.0):
            i = int(np.argmax(dz <= 0.0)) + 1
            raise DepthProfileError(
                f'{src}: depth not strictly increasing at row {i + 1} ({z[i] * 1e6:g} um)'
            )
        # Background-subtracted activities deep in the pin may scatter slightly below
        # zero: that is good data, not an error. The surface value must be positive.
        if a[0] <= 0.0:
            raise DepthProfileError(f'{src}: remaining activity at the surface must be > 0')
        if self.remaining_se_bq is not None:
            se = self.remaining_se_bq
            if se.shape != z.shape or not np.all(np.isfinite(se)) or np.any(se <= 0.0):
                raise DepthProfileError(f'{src}: remaining_activity_se_bq must be finite and > 0')


def read_layer_removal_csv(path: str | Path) -> LayerRemovalData:
    """Read ``depth_um,remaining_activity_bq[,remaining_activity_se_bq]`` (um, Bq, Bq).

    Lines starting with ``#`` are comments. Units are converted to SI (m).
    """
    p = Path(path)
    try:
        text = p.read_text(encoding='utf-8')
    except OSError as exc:
        raise DepthProfileError(f'cannot read depth profile {p}: {exc.strerror}') from None
    rows = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith('#')]
    if not rows:
        raise DepthProfileError(f'{p}: empty depth profile')
    reader = csv.DictReader(rows)
    fields = [f.strip() for f in (reader.fieldnames or [])]
    reader.fieldnames = fields
    for col in ('depth_um', 'remaining_activity_bq'):
        if col not in fields:
            raise DepthProfileError(f'{p}: missing column {col!r} (have {fields})')
    has_se = 'remaining_activity_se_bq' in fields
    z: list[float] = []
    a: list[float] = []
    se: list[float] = []
    for n, row in enumerate(reader, start=2):
        try:
            z.append(float(row['depth_um']) * 1e-6)
            a.append(float(row['remaining_activity_bq']))
            if has_se:
                se.append(float(row['remaining_activity_se_bq']))
        except (TypeError, ValueError):
            raise DepthProfileError(f'{p}: bad number in data row {n - 1}: {row}') from None
    return LayerRemovalData(
        np.asarray(z),
        np.asarray(a),
        np.asarray(se) if has_se else None,
        source=str(p),
    )


def _estimate_noise(A: FloatArray) -> FloatArray:
    """sigma_i [Bq] from fourth differences: Var(d4) = 70 sigma^2, sigma^2 = s0 + s2 A^2."""
    if A.size < 8:
        return np.full(A.size, max(float(np.std(np.diff(A))), 1e-12))
    d4 = np.diff(A, 4)
    v = d4 * d4 / 70.0
    Ac = A[2:-2]
    M = np.column_stack([np.ones_like(Ac), Ac * Ac])
    cs = np.linalg.norm(M, axis=0)
    cs[cs == 0.0] = 1.0
    ab, _ = nnls(M / cs, v)
    ab = ab / cs
    var = ab[0] + ab[1] * A * A
    floor = max(float(np.mean(v)) * 1e-3, 1e-24 * float(np.max(np.abs(A))) ** 2, 1e-300)
    return np.asarray(np.sqrt(np.maximum(var, floor)))


def _check_decreasing(data: LayerRemovalData, noise: FloatArray) -> None:
    """Raise if the raw remaining activity rises by more than 5 sigma or never falls."""
    a = data.remaining_bq
    src = data.source
    drop = a[0] - a[-1]
    total_noise = math.hypot(float(noise[0]), float(noise[-1]))
    if drop <= 5.0 * total_noise:
        raise ProfileNotDecreasingError(
            f'{src}: remaining activity does not decrease with depth '
            f'({a[0]:g} Bq at surface, {a[-1]:g} Bq at {data.depth_m[-1] * 1e6:g} um)'
        )
    d = np.diff(a)
    pair_noise = np.hypot(noise[1:], noise[:-1])
    bad = np.flatnonzero(d > 5.0 * pair_noise)
    if bad.size:
        i = int(bad[0]) + 1
        raise ProfileNotDecreasingError(
            f'{src}: remaining activity rises with depth at {data.depth_m[i] * 1e6:g} um '
            f'(+{d[i - 1]:g} Bq, noise {pair_noise[i - 1]:.3g} Bq): not a layer-removal profile'
        )
