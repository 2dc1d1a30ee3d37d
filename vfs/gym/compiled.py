"""Optional compiled (numba) kernel of the observation's gap between the outlines.

:func:`vfs.physics.geometry.rectangle_distance` is the reference.  It builds
the corners of both rectangles as (N, 4, 2) arrays, transforms them into the
other rectangle's frame and runs the separating-axis test: some forty array
operations, which cost the single environment more than the arithmetic (one
row) and the vector environment a pass over memory each (many rows).  This
kernel does the same per row in one loop: the same corner order, the same
products and sums in the same order of evaluation, float64 throughout, NaN
propagated as numpy's maximum and minimum propagate it.  The cosine and sine are the
only functions numpy and the kernel may evaluate with different code; where
they agree (numpy's float64 cos and sin call the C library's routines on the
machines we measured) the gaps are bit-identical, which
``tests/gym/test_compiled_observation.py`` checks.

Used by :func:`vfs.gym.observation.observe` where
:func:`vfs.physics.numba_support.enabled` (numba installed, ``VFS_COMPILED``
not "0").
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from vfs.physics.numba_support import require_numba

#: Corner signs along the long and the short axis, in the order of
#: :func:`vfs.physics.geometry.outline_corners` (as ``geometry._UNIT_CORNERS``).
_UX = (1.0, 1.0, -1.0, -1.0)
_UY = (-1.0, 1.0, 1.0, -1.0)


def _maximum(a: float, b: float) -> float:
    """numpy.maximum of two floats (NaN propagates)."""
    if a != a or a >= b:
        return a
    return b


def _minimum(a: float, b: float) -> float:
    """numpy.minimum of two floats (NaN propagates)."""
    if a != a or a <= b:
        return a
    return b


def _corner_distance(px: float, py: float, cx: float, cy: float, c: float, s: float,
                     hl: float, hw: float) -> float:
    """Distance [m] of point (px, py) to the rectangle (centre, axis (c, s), half sizes)."""
    dx = px - cx
    dy = py - cy
    x = c * dx + s * dy
    y = -s * dx + c * dy
    gx = _maximum(abs(x) - hl, 0.0)
    gy = _maximum(abs(y) - hw, 0.0)
    return math.sqrt(gx * gx + gy * gy)


def _gap_loop(ax: np.ndarray, ay: np.ndarray, ayaw: np.ndarray, ahl: np.ndarray,
              ahw: np.ndarray, bx: np.ndarray, by: np.ndarray, byaw: np.ndarray,
              bhl: np.ndarray, bhw: np.ndarray, ux: np.ndarray, uy: np.ndarray,
              out: np.ndarray) -> None:
    """:func:`vfs.physics.geometry.rectangle_distance` row by row (compiled by numba)."""
    for i in range(ax.shape[0]):
        acx, acy, bcx, bcy = ax[i], ay[i], bx[i], by[i]
        a_hl, a_hw, b_hl, b_hw = ahl[i], ahw[i], bhl[i], bhw[i]
        ca, sa = math.cos(ayaw[i]), math.sin(ayaw[i])
        cb, sb = math.cos(byaw[i]), math.sin(byaw[i])
        gap_a = math.inf  # corners of A to rectangle B
        gap_b = math.inf  # corners of B to rectangle A
        first = True
        for k in range(4):
            lx = a_hl * ux[k]
            ly = a_hw * uy[k]
            d1 = _corner_distance(acx + ca * lx - sa * ly, acy + sa * lx + ca * ly,
                                  bcx, bcy, cb, sb, b_hl, b_hw)
            lx = b_hl * ux[k]
            ly = b_hw * uy[k]
            d2 = _corner_distance(bcx + cb * lx - sb * ly, bcy + sb * lx + cb * ly,
                                  acx, acy, ca, sa, a_hl, a_hw)
            if first:
                gap_a, gap_b = d1, d2
                first = False
            else:
                gap_a = _minimum(gap_a, d1)
                gap_b = _minimum(gap_b, d2)
        gap = _minimum(gap_a, gap_b)
        dx = bcx - acx
        dy = bcy - acy
        ac = abs(ca * cb + sa * sb)
        as_ = abs(ca * sb - sa * cb)
        touch = (abs(ca * dx + sa * dy) <= a_hl + b_hl * ac + b_hw * as_) \
            and (abs(-sa * dx + ca * dy) <= a_hw + b_hl * as_ + b_hw * ac) \
            and (abs(cb * dx + sb * dy) <= b_hl + a_hl * ac + a_hw * as_) \
            and (abs(-sb * dx + cb * dy) <= b_hw + a_hl * as_ + a_hw * ac)
        out[i] = 0.0 if touch else gap


_compiled: list[Any] = []


def _kernel() -> Any:
    """The compiled :func:`_gap_loop` (compiled, or loaded from numba's cache, once)."""
    if not _compiled:
        import numba

        global _maximum, _minimum, _corner_distance
        jit = numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")
        _maximum = jit(_maximum)
        _minimum = jit(_minimum)
        _corner_distance = jit(_corner_distance)
        _compiled.append(numba.njit(cache=True, nogil=True, error_model="numpy")(_gap_loop))
    return _compiled[0]


def rectangle_distance_compiled(ax: npt.ArrayLike, ay: npt.ArrayLike, ayaw: npt.ArrayLike,
                                ahl: npt.ArrayLike, ahw: npt.ArrayLike, bx: npt.ArrayLike,
                                by: npt.ArrayLike, byaw: npt.ArrayLike, bhl: npt.ArrayLike,
                                bhw: npt.ArrayLike) -> np.ndarray:
    """:func:`vfs.physics.geometry.rectangle_distance` [m] (N,) by the compiled kernel.

    Same parameters (centres [m], orientations [rad], half sizes [m], arrays
    (N,) of any float type, computed in float64) and result (float64, 0 where
    the rectangles overlap or touch).

    Raises
    ------
    ParameterError
        Where numba is not installed.
    """
    require_numba()
    args = [np.asarray(a, dtype=float) for a in (ax, ay, ayaw, ahl, ahw, bx, by, byaw, bhl,
                                                 bhw)]
    shape = args[0].shape
    if len(shape) != 1 or any(a.shape != shape for a in args):  # the observation's (N,): no copy
        args = list(np.broadcast_arrays(*(np.atleast_1d(a) for a in args)))
    flat = [np.ascontiguousarray(a).reshape(-1) for a in args]
    out = np.empty(flat[0].shape[0])
    _kernel()(*flat, np.array(_UX), np.array(_UY), out)
    return out
