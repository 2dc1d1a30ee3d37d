"""Optional compiled (numba) kernel of the overlap clipping.

The numpy implementation in :mod:`vfs.physics.geometry` is the reference:
it is what the simulation uses and what the tests compare this kernel
against.  This module mirrors it pair by pair -- the same rectangle frame,
the same Sutherland-Hodgman stages in the same emitted vertex order (inside
run, exit crossing, entry crossing, padded with the entry crossing), the same
shoelace area and centroid relative to the first vertex -- in one compiled
loop without temporaries.  Only the order of the additions in the shoelace
sums differs (numpy sums a row pairwise, the loop sequentially), so areas
and centroids agree to rounding (a few ulp of the summands), not bit for bit;
``tests/test_compiled_overlap.py`` checks the agreement.

numba is a required dependency; :data:`AVAILABLE` is
False without it and :func:`overlap_compiled` then raises
:class:`vfs.errors.ParameterError`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from vfs.physics.core import clip_stage
from vfs.physics.geometry import AREA_TOLERANCE, Overlap, Polygons
from vfs.physics.numba_support import require_numba

try:  # pragma: no cover - depends on the environment
    import numba

    AVAILABLE = True
except ImportError:  # pragma: no cover
    numba = None  # type: ignore[assignment]
    AVAILABLE = False


def _overlap_loop(o1: np.ndarray, o2: np.ndarray, verts: np.ndarray, nonempty: np.ndarray,
                  area: np.ndarray, centroid: np.ndarray, tol: float) -> None:
    """Clip, area and centroid for every pair (compiled by numba)."""
    n, k = o1.shape[0], o1.shape[1]
    width = k + 4
    ax = np.empty(width)
    ay = np.empty(width)
    bx = np.empty(width)
    by = np.empty(width)
    dist = np.empty(width)
    for r in range(n):
        # rectangle frame of outline 2 (as geometry.rectangle_frame)
        cx0 = 0.5 * (o2[r, 0, 0] + o2[r, 2, 0])
        cy0 = 0.5 * (o2[r, 0, 1] + o2[r, 2, 1])
        alx = o2[r, 0, 0] - o2[r, 3, 0]
        aly = o2[r, 0, 1] - o2[r, 3, 1]
        acx = o2[r, 1, 0] - o2[r, 0, 0]
        acy = o2[r, 1, 1] - o2[r, 0, 1]
        length = np.hypot(alx, aly)
        c = alx / length
        s = aly / length
        hl = 0.5 * length
        hw = 0.5 * np.hypot(acx, acy)
        for j in range(k):
            dx = o1[r, j, 0] - cx0
            dy = o1[r, j, 1] - cy0
            ax[j] = c * dx + s * dy
            ay[j] = -s * dx + c * dy
        w = k
        alive = True
        # four stages, alternating buffers a -> b -> a -> b -> a
        if _clip_stage(ax, ay, w, 0, 1.0, hl, bx, by, dist) == 0:
            alive = False
        w += 1
        if _clip_stage(bx, by, w, 1, 1.0, hw, ax, ay, dist) == 0:
            alive = False
        w += 1
        if _clip_stage(ax, ay, w, 0, -1.0, -hl, bx, by, dist) == 0:
            alive = False
        w += 1
        if _clip_stage(bx, by, w, 1, -1.0, -hw, ax, ay, dist) == 0:
            alive = False
        w += 1
        nonempty[r] = alive
        if not alive:
            area[r] = 0.0
            centroid[r, 0] = np.nan
            centroid[r, 1] = np.nan
            for j in range(width):
                verts[r, j, 0] = np.nan
                verts[r, j, 1] = np.nan
            continue
        ox, oy = ax[0], ay[0]
        twice = 0.0
        sx = 0.0
        sy = 0.0
        for j in range(width):
            jn = j + 1 if j + 1 < width else 0
            rx, ry = ax[j] - ox, ay[j] - oy
            nx, ny = ax[jn] - ox, ay[jn] - oy
            cr = rx * ny - nx * ry
            twice += cr
            sx += (rx + nx) * cr
            sy += (ry + ny) * cr
        for j in range(width):
            verts[r, j, 0] = cx0 + c * ax[j] - s * ay[j]
            verts[r, j, 1] = cy0 + s * ax[j] + c * ay[j]
        if abs(twice) > 2.0 * tol:
            lx = sx / (3.0 * twice) + ox
            ly = sy / (3.0 * twice) + oy
            area[r] = 0.5 * twice
            centroid[r, 0] = cx0 + c * lx - s * ly
            centroid[r, 1] = cy0 + s * lx + c * ly
        else:
            area[r] = 0.0
            centroid[r, 0] = np.nan
            centroid[r, 1] = np.nan


_loop: Any = None
if AVAILABLE:  # pragma: no branch
    # the one Sutherland-Hodgman stage of the compiled code (vfs.physics.core)
    _clip_stage = numba.njit(cache=True, nogil=True, error_model="numpy")(clip_stage)
    _loop = numba.njit(cache=True, nogil=True, error_model="numpy")(_overlap_loop)


def overlap_compiled(outline1: npt.ArrayLike, outline2: npt.ArrayLike) -> Overlap:
    """Overlap polygon, area [m^2] and centroid [m] of N outline pairs, compiled kernel.

    Same contract as :func:`vfs.physics.geometry.overlap` (coordinates in m,
    outline 2 a rectangle in the corner order of
    :func:`vfs.physics.geometry.outline_corners`); empty overlaps carry NaN
    vertices, area 0 and a NaN centroid.

    Raises
    ------
    ParameterError
        Where numba is not installed.
    """
    require_numba()
    o1 = np.ascontiguousarray(outline1, dtype=float)
    o2 = np.ascontiguousarray(outline2, dtype=float)
    n, k = o1.shape[:2]
    verts = np.empty((n, k + 4, 2))
    nonempty = np.empty(n, dtype=bool)
    area = np.empty(n)
    centroid = np.empty((n, 2))
    _loop(o1, o2, verts, nonempty, area, centroid, AREA_TOLERANCE)
    return Overlap(Polygons(verts, nonempty), area, centroid)
