"""Sensor geometry: whether an object's outline lies inside a field-of-view sector.

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
    axis-aligned box [-hl, hl] x [-hw, hw] (slab method); inf if missed.
    """

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
