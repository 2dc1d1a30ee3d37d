"""Sensor geometry: is an object's outline inside a field-of-view sector?

The sector has its apex at the sensor, a boresight direction, an opening
angle 2 alpha and a radius R.  An object is visible when its outline
rectangle intersects the sector, i.e. when the smallest distance from the
apex to the part of the rectangle inside the angular wedge is at most R.
That distance is found exactly without clipping (docs/aeb.md, section 2):
split the wedge into its two halves [-alpha, 0] and [0, alpha], each convex;
on a convex set the minimum of |p| lies either at the unconstrained closest
point of the rectangle (if that point is inside the wedge) or on one of the
bounding rays, where it is the entry distance of the ray into the rectangle
(slab method).  So the distance is the smallest of: the closest-point
distance (when its bearing is within +-alpha) and the entry distances of the
rays at -alpha, 0 and +alpha.
"""

from __future__ import annotations

import numpy as np

from vfs.units import wrap_angle

#: Ray direction components below this count as parallel to a rectangle side.
_PARALLEL = 1e-12


def _ray_entry(lx: np.ndarray, ly: np.ndarray, ex: np.ndarray, ey: np.ndarray,
               hl: np.ndarray, hw: np.ndarray) -> np.ndarray:
    """Entry distance [m] of rays from (lx, ly) along unit (ex, ey) into the
    axis-aligned box [-hl, hl] x [-hw, hw] (slab method); inf if missed."""

    def slab(origin: np.ndarray, direction: np.ndarray,
             half: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        parallel = np.abs(direction) < _PARALLEL
        safe = np.where(parallel, 1.0, direction)
        t1 = (-half - origin) / safe
        t2 = (half - origin) / safe
        inside = np.abs(origin) <= half
        lo = np.where(parallel, np.where(inside, -np.inf, np.inf), np.minimum(t1, t2))
        hi = np.where(parallel, np.where(inside, np.inf, -np.inf), np.maximum(t1, t2))
        return lo, hi

    lo_x, hi_x = slab(lx, ex, hl)
    lo_y, hi_y = slab(ly, ey, hw)
    enter = np.maximum(np.maximum(lo_x, lo_y), 0.0)
    leave = np.minimum(hi_x, hi_y)
    return np.where(leave >= enter, enter, np.inf)


def sector_distance(sx: np.ndarray, sy: np.ndarray, boresight: np.ndarray, half_angle: float,
                    cx: np.ndarray, cy: np.ndarray, yaw: np.ndarray,
                    hl: np.ndarray, hw: np.ndarray) -> np.ndarray:
    """Distance [m] from the sensor to the part of each rectangle inside its wedge.

    Parameters
    ----------
    sx, sy : ndarray (n,)
        Sensor positions [m].
    boresight : ndarray (n,)
        Boresight directions [rad].
    half_angle : float
        Half the opening angle, alpha [rad]; >= pi means all around.
    cx, cy, yaw : ndarray (n,)
        Centres [m] and orientations [rad] of the object rectangles.
    hl, hw : ndarray (n,)
        Their half length and half width [m].

    Returns
    -------
    ndarray (n,)
        The distance [m]; 0 where the sensor lies inside the rectangle; inf
        where no part of the rectangle is inside the wedge.
    """
    c, s = np.cos(yaw), np.sin(yaw)
    dx, dy = sx - cx, sy - cy
    lx = c * dx + s * dy  # sensor in the rectangle's frame
    ly = -s * dx + c * dy
    qx = np.clip(lx, -hl, hl) - lx  # sensor -> closest point, rectangle frame
    qy = np.clip(ly, -hw, hw) - ly
    closest = np.hypot(qx, qy)
    if half_angle >= np.pi:
        return closest
    bearing = wrap_angle(np.arctan2(qy, qx) + yaw - boresight)
    inside = closest == 0.0
    best = np.where(inside | (np.abs(bearing) <= half_angle), closest, np.inf)
    for offset in (-half_angle, 0.0, half_angle):
        phi = boresight + offset - yaw  # ray direction in the rectangle's frame
        best = np.minimum(best, _ray_entry(lx, ly, np.cos(phi), np.sin(phi), hl, hw))
    return best


def outline_visible(sx: np.ndarray, sy: np.ndarray, boresight: np.ndarray, field_of_view: float,
                    max_range: float, cx: np.ndarray, cy: np.ndarray, yaw: np.ndarray,
                    hl: np.ndarray, hw: np.ndarray) -> np.ndarray:
    """True where the rectangle intersects the sensor's field-of-view sector.

    ``field_of_view`` is the full opening angle [rad] (2 pi = all around),
    ``max_range`` the sector radius [m]; the other arguments as in
    :func:`sector_distance`.
    """
    return sector_distance(sx, sy, boresight, 0.5 * field_of_view, cx, cy, yaw, hl, hw) \
        <= max_range


def _corners_to_box(px: np.ndarray, py: np.ndarray, c: np.ndarray, s: np.ndarray,
                    hl_b: np.ndarray, hw_b: np.ndarray, hl_a: np.ndarray,
                    hw_a: np.ndarray) -> np.ndarray:
    """Smallest squared distance [m^2] of the corners of rectangle B to the axis-aligned
    box A.

    B's centre is (px, py) in A's frame, its axis at angle (c, s) = (cos, sin)
    of the relative yaw; half sizes hl, hw [m].  (Unrolled over the four
    corners: one-dimensional array operations only.)
    """
    u1, u2, v1, v2 = hl_b * c, hl_b * s, hw_b * s, hw_b * c
    xa, xb, ya, yb = px + u1, px - u1, py + u2, py - u2
    best = None
    for x, y in ((xa - v1, ya + v2), (xa + v1, ya - v2), (xb - v1, yb + v2),
                 (xb + v1, yb - v2)):
        gx = np.maximum(np.abs(x) - hl_a, 0.0)
        gy = np.maximum(np.abs(y) - hw_a, 0.0)
        d2 = gx * gx + gy * gy
        best = d2 if best is None else np.minimum(best, d2)
    return best  # type: ignore[return-value]


def rectangle_gap(ax: np.ndarray, ay: np.ndarray, ayaw: np.ndarray, ahl: np.ndarray,
                  ahw: np.ndarray, bx: np.ndarray, by: np.ndarray, byaw: np.ndarray,
                  bhl: np.ndarray, bhw: np.ndarray) -> np.ndarray:
    """Distance [m] between rectangles A and B (centres, yaws [rad], half sizes [m]); 0 if
    they overlap.

    Overlap by the separating-axis test on the four edge normals; otherwise
    the smallest distance of a corner of either rectangle to the other (the
    closest points of disjoint convex polygons include a vertex).
    """
    ca, sa = np.cos(ayaw), np.sin(ayaw)
    cb, sb = np.cos(byaw), np.sin(byaw)
    dx, dy = bx - ax, by - ay
    c, s = ca * cb + sa * sb, ca * sb - sa * cb  # relative yaw of B in A's frame
    pxa, pya = ca * dx + sa * dy, -sa * dx + ca * dy  # B's centre in A's frame
    pxb, pyb = -(cb * dx + sb * dy), -(-sb * dx + cb * dy)  # A's centre in B's frame
    ac, as_ = np.abs(c), np.abs(s)
    overlap = ((np.abs(pxa) <= ahl + bhl * ac + bhw * as_)
               & (np.abs(pya) <= ahw + bhl * as_ + bhw * ac)
               & (np.abs(pxb) <= bhl + ahl * ac + ahw * as_)
               & (np.abs(pyb) <= bhw + ahl * as_ + ahw * ac))
    d2 = np.minimum(_corners_to_box(pxa, pya, c, s, bhl, bhw, ahl, ahw),
                    _corners_to_box(pxb, pyb, c, -s, ahl, ahw, bhl, bhw))
    return np.where(overlap, 0.0, np.sqrt(d2))
