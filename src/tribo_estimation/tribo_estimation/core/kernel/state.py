"""The integrated state ``y`` as a fixed-length tuple: the kernel's only tuple builders.

``y`` holds :data:`.layout.NY` floats (indices ``Y_*``; entry ``j`` is slot
``Y_SLOTS[j]`` of the state vector ``s``); the right-hand side returns
:data:`.layout.ND` floats (the derivatives of ``y`` in the same order, then the
friction moment at ``D_M``). numba compiles a homogeneous tuple of constant length
to registers, and the loops below over ``range(NY)`` unroll, so carrying ``y``
generically costs nothing against a hand-written argument list. Every tuple the
kernel builds is built here (or by :func:`with_entry` on a tuple of the table's
length), so its length follows the state table of :mod:`.layout` without edits.

The functions also run as plain Python (``NUMBA_DISABLE_JIT=1``): :func:`with_entry`
has a Python body and a numba implementation.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numba.core.extending import overload
from numba.cpython.unsafe.tuple import tuple_setitem
from numpy.typing import NDArray

from .layout import NY, Y_SLOTS, Y_ZERO

FloatArray = NDArray[np.float64]
FloatTuple = tuple[float, ...]

#: The kernel's fast-math flags (every jitted kernel function uses these).
FASTMATH = {'contract', 'arcp', 'afn', 'reassoc', 'nsz'}
#: The kernel's fast-math flags without reassociation (sums in the written order).
_FASTMATH_FIXED_ORDER = {'contract', 'arcp', 'afn', 'nsz'}


def with_entry(tup: FloatTuple, j: int, value: float) -> FloatTuple:
    """Return a copy of the float tuple ``tup`` with entry ``j`` replaced by ``value``.

    Parameters
    ----------
    tup : tuple of float
        A state or right-hand-side tuple (``y`` or the derivatives).
    j : int
        Index (``Y_*`` or ``D_M``).
    value : float
        New value (in the tuple's unit at that index).

    Returns
    -------
    tuple of float
        The new tuple (same length).
    """
    return (*tup[:j], float(value), *tup[j + 1 :])


@overload(with_entry)
def _with_entry_numba(tup: object, j: object, value: object) -> object:
    # numba's implementation of with_entry (numba requires the same annotations on
    # the typing function, which receives numba types, and on the implementation)
    def impl(tup: object, j: object, value: object) -> object:  # pragma: no cover
        return tuple_setitem(tup, j, value)  # type: ignore[call-arg]

    return impl


@njit(cache=True, error_model='numpy', fastmath=FASTMATH)
def from_state(s: FloatArray) -> FloatTuple:
    """Return the integrated state ``y`` read from the state vector ``s``.

    Parameters
    ----------
    s : FloatArray
        State vector (length ``NS``, indices ``S_*``).

    Returns
    -------
    tuple of float
        ``y`` (length ``NY``, indices ``Y_*``), in the slots' units.
    """
    y = Y_ZERO
    for j in range(NY):
        y = with_entry(y, j, s[Y_SLOTS[j]])
    return y


@njit(cache=True, error_model='numpy', fastmath=FASTMATH)
def to_state(y: FloatTuple, s: FloatArray) -> None:
    """Write the integrated state ``y`` into its slots of the state vector ``s``.

    Parameters
    ----------
    y : tuple of float
        Integrated state (length ``NY``, indices ``Y_*``).
    s : FloatArray
        State vector (length ``NS``), updated in place.
    """
    for j in range(NY):
        s[Y_SLOTS[j]] = y[j]


@njit(cache=True, error_model='numpy', fastmath=FASTMATH)
def axpy(y: FloatTuple, a: float, k: FloatTuple) -> FloatTuple:
    """Return ``y + a*k`` over the ``NY`` integrated entries (``k`` may be longer).

    Parameters
    ----------
    y : tuple of float
        Integrated state (length ``NY``).
    a : float
        Step [s].
    k : tuple of float
        Right-hand side (length ``ND`` >= ``NY``; entries past ``NY`` are ignored).

    Returns
    -------
    tuple of float
        The stage state (length ``NY``).
    """
    out = y
    for j in range(NY):
        out = with_entry(out, j, y[j] + a * k[j])
    return out


@njit(cache=True, error_model='numpy', fastmath=_FASTMATH_FIXED_ORDER)
def rk4_combine(
    y: FloatTuple,
    h6: float,
    k1: FloatTuple,
    k2: FloatTuple,
    k3: FloatTuple,
    k4: FloatTuple,
) -> FloatTuple:
    """Return the classical RK4 update ``y + h6*(k1 + 2 k2 + 2 k3 + k4)`` (``h6 = h/6``).

    Summed in one fixed order, ``y + ((2*(k2 + k3) + k1) + k4)*h6``, compiled without
    reassociation: the rounding of every entry is the same whatever the compiler
    inlines around it (and whatever the length of ``y``).

    Parameters
    ----------
    y : tuple of float
        Integrated state at the step start (length ``NY``).
    h6 : float
        Sixth of the step [s].
    k1, k2, k3, k4 : tuple of float
        The four stages' right-hand sides (length ``ND``).

    Returns
    -------
    tuple of float
        The state at the step end (length ``NY``).
    """
    out = y
    for j in range(NY):
        out = with_entry(out, j, y[j] + (((k2[j] + k3[j]) * 2.0 + k1[j]) + k4[j]) * h6)
    return out
