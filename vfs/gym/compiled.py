"""Compiled (numba) kernels of the observation: the gap between the outlines and the
whole sensor observation.

:func:`sensor_kernel` computes the sensor observation of
:func:`vfs.gym.observation.observe_reference` row by row in one call per step: the same
float32 products and sums in the same order, the gap and the TTC in float64 as there, the
cos and sin of the yaws and of the boresight taken from numpy (float32, as the reference
evaluates them), and the exact visibility test left to the reference's numpy function
for the objects near the edges of the field of view (:func:`_outside_wedge` decides the
clear cases, by a margin far above the rounding).  ``tests/gym/test_fast_observation.py``
compares the two bit for bit along whole episodes.

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


def _gap_row(acx: float, acy: float, ayaw: float, a_hl: float, a_hw: float, bcx: float,
             bcy: float, byaw: float, b_hl: float, b_hw: float, ux: np.ndarray,
             uy: np.ndarray) -> float:
    """:func:`vfs.physics.geometry.rectangle_distance` [m] of one pair (float64)."""
    ca, sa = math.cos(ayaw), math.sin(ayaw)
    cb, sb = math.cos(byaw), math.sin(byaw)
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
    return 0.0 if touch else gap


def _gap_loop(ax: np.ndarray, ay: np.ndarray, ayaw: np.ndarray, ahl: np.ndarray,
              ahw: np.ndarray, bx: np.ndarray, by: np.ndarray, byaw: np.ndarray,
              bhl: np.ndarray, bhw: np.ndarray, ux: np.ndarray, uy: np.ndarray,
              out: np.ndarray) -> None:
    """:func:`vfs.physics.geometry.rectangle_distance` row by row (compiled by numba)."""
    for i in range(ax.shape[0]):
        out[i] = _gap_row(ax[i], ay[i], ayaw[i], ahl[i], ahw[i], bx[i], by[i], byaw[i],
                          bhl[i], bhw[i], ux, uy)


def _clip32(v: Any, lo: Any, hi: Any) -> Any:
    """numpy.clip of one float32 (NaN stays NaN, -0.0 stays -0.0 inside the bounds)."""
    if v != v:
        return v
    if v < lo:
        return lo
    if v > hi:
        return hi
    return v


#: Margins of :func:`_outside_wedge`: angle [rad] and distance beyond the circle [m].
WEDGE_MARGIN = 1e-3
WEDGE_CLEARANCE = 0.5


def _outside_wedge(dx: float, dy: float, bx: float, by: float, dist: float, radius: float,
                   half_angle: float) -> bool:
    """Whether a circle (centre (dx, dy) [m] from the sensor at distance ``dist``, radius
    ``radius`` [m]) lies wholly outside the wedge of half opening ``half_angle`` [rad]
    < pi about the boresight (bx, by), by at least :data:`WEDGE_MARGIN`.

    The circle subtends the bearings within asin(radius / dist) of its centre's; where
    they all lie beyond the wedge, no point of the outline inside the circle is in the
    field of view, so :func:`vfs.adas.sensor.outline_visible` says "not seen".  The
    margins (1 mrad, the sensor at least :data:`WEDGE_CLEARANCE` outside the circle) are
    far above the rounding of the float32 exact test (about 1e-5 m at 150 m), so the two
    decide alike; the rows near the wedge's edges go to the exact test.
    """
    if dist < radius + WEDGE_CLEARANCE:
        return False
    off = abs(math.atan2(dx * by - dy * bx, dx * bx + dy * by))
    return off - math.asin(radius / dist) > half_angle + WEDGE_MARGIN


def _sensor_rows(x: np.ndarray, y: np.ndarray, yaw: np.ndarray, yc: np.ndarray,
                 ys: np.ndarray, speed: np.ndarray, accel: np.ndarray, vx: np.ndarray,
                 vy: np.ndarray, mu: np.ndarray, rows: np.ndarray, ef_all: np.ndarray,
                 er_all: np.ndarray, ew_all: np.ndarray, of_all: np.ndarray,
                 or_all: np.ndarray, ow_all: np.ndarray, e: int, o: int,
                 boresight: bool, bx: np.ndarray, by: np.ndarray, mount_x: Any,
                 mount_y: Any, narrow: bool, half_angle: float, cos_half: Any,
                 max_range: Any, friction: bool,
                 low: np.ndarray, high: np.ndarray, ux: np.ndarray, uy: np.ndarray,
                 seen_in: np.ndarray, second: bool, out: np.ndarray, unsure: np.ndarray,
                 aux: np.ndarray) -> None:
    """The sensor observation (:func:`vfs.gym.observation.observe_reference`) row by row.

    float32 where the reference computes in float32 (every product and sum in its order),
    float64 for the gap and the TTC as there; ``yc``, ``ys`` (n, 2) are numpy's float32
    cos and sin of the yaws [rad] (and ``bx``, ``by`` those of the boresight where
    ``boresight``), so that no transcendental function is evaluated by other code than the
    reference's.  The exact visibility test of the rows that the quick decisions leave
    open is the reference's (numpy): such rows are flagged in ``unsure`` with the sensor
    position, the object's centre and half sizes [m] in ``aux`` (n, 6); the caller
    decides them and calls again with ``second`` and their ``seen_in`` (0/1; -1 elsewhere:
    the row is skipped).
    """
    half = np.float32(0.5)
    eps_norm: Any = np.float32(1e-9)
    eps_closing: Any = np.float32(1e-12)
    for i in range(x.shape[0]):
        if second and seen_in[i] < 0:
            continue
        r = rows[i]
        ce = yc[i, e]
        se = ys[i, e]
        co = yc[i, o]
        so = ys[i, o]
        ox = np.float32(x[i, o] - x[i, e])
        oy = np.float32(y[i, o] - y[i, e])
        ef = ef_all[r]
        er = er_all[r]
        ew = ew_all[r]
        of = of_all[r]
        orr = or_all[r]
        ow = ow_all[r]
        e_c = half * (ef - er)  # geometric centre ahead of the CG
        o_c = half * (of - orr)
        ecx = e_c * ce
        ecy = e_c * se
        ocx = ox + o_c * co
        ocy = oy + o_c * so
        ehl = half * (ef + er)
        ohl = half * (of + orr)
        ohw = half * ow
        dx = ocx - ef * ce
        dy = ocy - ef * se
        dvx = np.float32(vx[i, o]) - np.float32(vx[i, e])
        dvy = np.float32(vy[i, o]) - np.float32(vy[i, e])
        rel_x = ce * dx + se * dy
        rel_y = -se * dx + ce * dy
        rel_vx = ce * dvx + se * dvy
        rel_vy = -se * dvx + ce * dvy
        closing = -(dx * dvx + dy * dvy) / _maximum(np.sqrt(dx * dx + dy * dy), eps_norm)
        if second:
            seen = seen_in[i] == 1
        else:
            mx = ef + mount_x
            sx = ce * mx - se * mount_y
            sy = se * mx + ce * mount_y
            bxi = bx[i] if boresight else ce
            byi = by[i] if boresight else se
            dxs = ocx - sx
            dys = ocy - sy
            dist = np.sqrt(dxs * dxs + dys * dys)
            ahead = (dxs * bxi + dys * byi) >= cos_half * dist if narrow else True
            seen = dist <= max_range and ahead
            radius = np.sqrt(ohl * ohl + ohw * ohw)  # of the object's bounding circle
            open_ = not seen and dist - radius <= max_range
            if open_ and narrow:
                open_ = not _outside_wedge(np.float64(dxs), np.float64(dys),
                                           np.float64(bxi), np.float64(byi),
                                           np.float64(dist), np.float64(radius), half_angle)
            unsure[i] = 1 if open_ else 0
            if open_:
                aux[i, 0] = sx
                aux[i, 1] = sy
                aux[i, 2] = ocx
                aux[i, 3] = ocy
                aux[i, 4] = ohl
                aux[i, 5] = ohw
        # the gap (4 cos and sin) only where it is observed: unseen, gap x 0 is 0 or NaN
        # (cleared to 0) whatever the gap (>= 0), and the TTC is TTC_NONE
        gap = 0.0
        ttc = 10.0
        if seen:
            gap = _gap_row(np.float64(ecx), np.float64(ecy),
                           np.float64(np.float32(yaw[i, e])), np.float64(ehl),
                           np.float64(half * ew), np.float64(ocx), np.float64(ocy),
                           np.float64(np.float32(yaw[i, o])), np.float64(ohl),
                           np.float64(ohw), ux, uy)
            if closing > 0.0:
                ttc = gap / np.float64(_maximum(closing, eps_closing))
        sf = np.float32(1.0) if seen else np.float32(0.0)
        cols = (np.float32(speed[i, e]), np.float32(accel[i, e]), sf,
                np.float32(gap * (1.0 if seen else 0.0)), rel_x * sf, rel_y * sf,
                rel_vx * sf, rel_vy * sf, np.float32(ttc),
                np.float32(mu[i]) if friction else np.float32(0.0))
        for k in range(10):
            v = _clip32(cols[k], low[k], high[k])
            out[i, k] = np.float32(0.0) if v != v else v


_compiled: list[Any] = []


def _kernel() -> Any:
    """The compiled :func:`_gap_loop` (compiled, or loaded from numba's cache, once)."""
    if not _compiled:
        import numba

        global _maximum, _minimum, _corner_distance, _gap_row, _clip32, _outside_wedge
        jit = numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")
        _maximum = jit(_maximum)
        _minimum = jit(_minimum)
        _corner_distance = jit(_corner_distance)
        _clip32 = jit(_clip32)
        _outside_wedge = jit(_outside_wedge)
        _gap_row = jit(_gap_row)
        opts = {"cache": True, "nogil": True, "error_model": "numpy"}
        _compiled.append(numba.njit(**opts)(_gap_loop))
        _compiled.append(numba.njit(**opts)(_sensor_rows))
    return _compiled[0]


def sensor_kernel() -> Any:
    """The compiled :func:`_sensor_rows` (:func:`vfs.gym.observation.observe` calls it)."""
    require_numba()
    _kernel()
    return _compiled[1]


#: Corner signs as arrays (arguments of the kernels).
UNIT_CORNERS = (np.array(_UX), np.array(_UY))


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
