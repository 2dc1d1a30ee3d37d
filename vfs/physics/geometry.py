"""Collision geometry: vehicle outlines, overlap polygon, point of impact and contact plane.

Everything here works on arrays of N vehicle pairs at once (shape ``(N, ...)``)
and on one pair (N = 1); there is no per-pair Python loop.

The rules follow the Momentum Based Impact Model paper, section 3.2.1 (its X-RATE/PC-Crash
VFS): the outlines are rectangles, the overlap region is found by the
Sutherland-Hodgman algorithm, the point of impact (POI) is the centroid of the
overlap polygon (Nuernberg's formulas = shoelace area and centroid), and the
contact plane (CP) runs through the intersection points of the two outlines,
translated in parallel through the POI.  The cases where that simple rule
breaks down are resolved as documented in :func:`contact_plane` and in
docs/physics.md.

Polygons are stored as ``(N, MAX_VERTICES, 2)`` arrays plus a vertex count
``(N,)``; vertices beyond the count are NaN.  Outline vertices are
counter-clockwise.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from vfs.physics.vehicle import VehicleArrays

#: Convex quadrilateral clipped by four half-planes has at most 4 + 4 vertices.
MAX_VERTICES = 8

#: Rows clipped per block; keeps the temporaries in the CPU cache.
CHUNK = 4096

# index tables for the clipping stages: slot numbers and cyclic rolls, by polygon width
_SLOTS = {w: np.arange(w) for w in range(3, 2 * MAX_VERTICES + 1)}
_ROLLS = {w: (np.arange(w)[:, None] + np.arange(w)[None, :]) % w for w in _SLOTS}
_PREV = {w: np.roll(np.arange(w), 1) for w in _SLOTS}
_ONES_U8 = {w: np.ones(w, dtype=np.uint8) for w in _SLOTS}

#: Overlap areas below this [m^2] count as touching, not penetrating.
AREA_TOLERANCE = 1e-9

#: Intersection points closer than this [m] are one point.
POINT_TOLERANCE = 1e-7


class Polygons(NamedTuple):
    """N convex polygons with a fixed number of vertex slots.

    Attributes
    ----------
    vertices : ndarray, shape (N, W, 2)
        Vertex coordinates [m], counter-clockwise.  A polygon with fewer than
        W vertices is padded with copies of its last vertex (zero-length
        edges), so every slot is a valid vertex and the shoelace sums need no
        mask.
    nonempty : ndarray of bool, shape (N,)
        False where the polygon is empty (its slots then hold no meaning).
    """

    vertices: np.ndarray
    nonempty: np.ndarray


class ContactGeometry(NamedTuple):
    """Result of :func:`contact_geometry` for N vehicle pairs.

    Attributes
    ----------
    overlap_polygon : Polygons
        The overlap polygon of the two outlines [m].
    area : ndarray (N,)
        Overlap area [m^2].
    poi : ndarray (N, 2)
        Point of impact [m], global frame: centroid of the overlap polygon;
        for touching outlines the mean of the touching points; NaN when the
        outlines neither overlap nor touch.
    cp_angle : ndarray (N,)
        Direction of the contact-plane tangent [rad] in [0, pi); NaN when
        there is no contact.
    n_intersections : ndarray of int (N,)
        Number of distinct intersection points of the two outline boundaries.
    rule : ndarray of int (N,)
        Which contact-plane rule was applied, see :data:`CP_RULES`.
    """

    overlap_polygon: Polygons
    area: np.ndarray
    poi: np.ndarray
    cp_angle: np.ndarray
    n_intersections: np.ndarray
    rule: np.ndarray


#: Contact-plane rules, by code (see :func:`contact_plane` and docs/physics.md).
CP_RULES: dict[int, str] = {
    0: "no contact",
    1: "line through the two intersection points (the Momentum Based Impact Model paper)",
    2: "line through the two intersection points farthest apart (more than two)",
    3: "perpendicular to the line between the CGs (containment or coincident points)",
    4: "along the touching edges (zero overlap area)",
}


# ----------------------------------------------------------------------------
# Outlines
# ----------------------------------------------------------------------------


def outline_corners(
    x: npt.ArrayLike, y: npt.ArrayLike, yaw: npt.ArrayLike,
    cg_to_front: npt.ArrayLike, cg_to_rear: npt.ArrayLike, width: npt.ArrayLike,
) -> np.ndarray:
    """Corners of vehicle outline rectangles in the global frame.

    Parameters
    ----------
    x, y : array_like (N,)
        CG position [m].
    yaw : array_like (N,)
        Heading of the vehicle's x axis [rad], counter-clockwise from global x.
    cg_to_front, cg_to_rear : array_like (N,)
        Distance from the CG to the front / rear bumper [m].
    width : array_like (N,)
        Outline width [m].

    Returns
    -------
    ndarray (N, 4, 2)
        Corners [m] counter-clockwise: front-right, front-left, rear-left,
        rear-right.
    """
    x, y, yaw, front, rear, width = np.broadcast_arrays(
        *(np.atleast_1d(np.asarray(a, float)) for a in (x, y, yaw, cg_to_front, cg_to_rear, width))
    )
    half = 0.5 * width
    local_x = np.stack([front, front, -rear, -rear], axis=-1)  # (N, 4) vehicle frame [m]
    local_y = np.stack([-half, half, half, -half], axis=-1)
    c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
    gx = x[:, None] + c * local_x - s * local_y
    gy = y[:, None] + s * local_x + c * local_y
    return np.stack([gx, gy], axis=-1)


def vehicle_outline(
    vehicles: VehicleArrays, x: npt.ArrayLike, y: npt.ArrayLike, yaw: npt.ArrayLike
) -> np.ndarray:
    """Outline corners (N, 4, 2) [m] of vehicles at CG pose (x, y [m], yaw [rad])."""
    return outline_corners(x, y, yaw, vehicles.cg_to_front, vehicles.cg_to_rear, vehicles.width)


def to_vehicle_frame(
    points: npt.ArrayLike, x: npt.ArrayLike, y: npt.ArrayLike, yaw: npt.ArrayLike
) -> np.ndarray:
    """Express global points (N, 2) [m] in the frames of vehicles at (x, y, yaw)."""
    p = np.atleast_2d(np.asarray(points, float))
    dx = p[:, 0] - np.asarray(x, float)
    dy = p[:, 1] - np.asarray(y, float)
    c, s = np.cos(yaw), np.sin(yaw)
    return np.stack([c * dx + s * dy, -s * dx + c * dy], axis=-1)


# ----------------------------------------------------------------------------
# Sutherland-Hodgman clipping
# ----------------------------------------------------------------------------


def _clip_half_plane(
    px: np.ndarray, py: np.ndarray, axis: int, sign: float, bound: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One Sutherland-Hodgman stage: clip convex polygons by ``sign * (bound - coord) >= 0``.

    ``px, py`` (N, W) hold the vertices of N convex polygons, padded with
    copies of their last vertex (zero-length edges, which change neither the
    clipping nor the shoelace sums); ``axis`` 0 clips on x, 1 on y; ``bound``
    (N,) is the clip line.  Returns the clipped polygons, width W + 1, padded
    the same way, and a flag (N,) that is False where nothing is left.

    Sutherland-Hodgman emits, for every edge (s -> e): the crossing point when
    the edge crosses the clip line, then e when e is inside.  For a convex
    polygon the inside vertices form one contiguous run (cyclically) and there
    are zero or two crossings, so the emitted sequence, started at the first
    inside vertex after the entry crossing, is: the inside run, the exit
    crossing, the entry crossing.  Building it in that order (a per-row roll)
    replaces the generic compaction of the emitted points by one gather.
    """
    n, width = px.shape
    slots = _SLOTS[width]
    coord = px if axis == 0 else py
    dist = sign * (bound[:, None] - coord)  # >= 0 inside
    inside = dist >= 0.0
    # count by a small matrix product: much faster than a boolean reduction
    n_in = (inside.view(np.uint8) @ _ONES_U8[width]).astype(np.int64)
    entry = inside & ~inside[:, _PREV[width]]
    crossing = (n_in > 0) & (n_in < width)  # then exactly one entry and one exit
    start = entry.argmax(axis=1)  # 0 where no crossing: keep the order
    # rolled vertex order as flat indices into the (n, width) arrays
    order = _ROLLS[width][start]
    flat = order + (np.arange(n) * width)[:, None]
    rx = px.take(flat)
    ry = py.take(flat)
    rd = dist.take(flat)
    rows = np.arange(n)
    last_in = np.maximum(n_in - 1, 0)
    first_out = np.where(n_in < width, n_in, 0)
    # signed distances at the ends of the exit edge (last inside -> first
    # outside) and of the entry edge (last -> first of the rolled sequence)
    d_in, d_out = rd[rows, last_in], rd[rows, first_out]
    d_last, d_first = rd[:, -1], rd[:, 0]
    other_r = ry if axis == 0 else rx
    o_in, o_out = other_r[rows, last_in], other_r[rows, first_out]
    with np.errstate(invalid="ignore", divide="ignore"):
        exit_other = o_in + d_in / (d_in - d_out) * (o_out - o_in)
        o_last, o_first = other_r[:, -1], other_r[:, 0]
        entry_other = o_last + d_last / (d_last - d_first) * (o_first - o_last)
    # crossing points lie exactly on the clip line
    if axis == 0:
        exit_x, exit_y, entry_x, entry_y = bound, exit_other, bound, entry_other
    else:
        exit_x, exit_y, entry_x, entry_y = exit_other, bound, entry_other, bound
    out_x = np.empty((n, width + 1))
    out_y = np.empty((n, width + 1))
    keep = slots[None, :] < n_in[:, None]
    out_x[:, :width] = np.where(keep, rx, entry_x[:, None])
    out_y[:, :width] = np.where(keep, ry, entry_y[:, None])
    out_x[:, width] = np.where(crossing, entry_x, rx[:, -1])
    out_y[:, width] = np.where(crossing, entry_y, ry[:, -1])
    r = rows[crossing]
    m = n_in[crossing]
    out_x[r, m] = exit_x[crossing]
    out_y[r, m] = exit_y[crossing]
    return out_x, out_y, n_in > 0


class RectangleFrame(NamedTuple):
    """Local frame of N rectangles: centre [m], unit x axis, half length and half width [m]."""

    centre: np.ndarray  # (N, 2) [m]
    axis: np.ndarray  # (N, 2) unit vector of the rectangle's x axis
    half_length: np.ndarray  # (N,) [m]
    half_width: np.ndarray  # (N,) [m]

    def to_local(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Global points (N, K, 2) [m] -> local coordinates (x, y), each (N, K)."""
        dx = points[..., 0] - self.centre[:, 0:1]
        dy = points[..., 1] - self.centre[:, 1:2]
        c, s = self.axis[:, 0:1], self.axis[:, 1:2]
        return c * dx + s * dy, -s * dx + c * dy

    def to_global(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Local coordinates (N, K) -> global points (N, K, 2) [m]."""
        c, s = self.axis[:, 0:1], self.axis[:, 1:2]
        gx = self.centre[:, 0:1] + c * x - s * y
        gy = self.centre[:, 1:2] + s * x + c * y
        return np.stack([gx, gy], axis=-1)


def rectangle_frame(corners: np.ndarray) -> RectangleFrame:
    """Frame of outline rectangles given as corners (N, 4, 2) [m] in the order of
    :func:`outline_corners` (front-right, front-left, rear-left, rear-right).
    """
    centre = 0.5 * (corners[:, 0] + corners[:, 2])  # midpoint of a diagonal
    along = corners[:, 0] - corners[:, 3]  # rear-right -> front-right
    across = corners[:, 1] - corners[:, 0]  # front-right -> front-left
    length = np.hypot(along[:, 0], along[:, 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        axis = along / length[:, None]
    return RectangleFrame(centre, axis, 0.5 * length, 0.5 * np.hypot(across[:, 0], across[:, 1]))


def clip_outlines(subject: npt.ArrayLike, clip: npt.ArrayLike) -> Polygons:
    """Overlap polygons of convex ``subject`` polygons clipped by outline rectangles ``clip``.

    Sutherland-Hodgman (1974) clipping of each subject polygon against the
    four half-planes of the clip rectangle, carried out in the clip
    rectangle's own frame, where the clip window is axis-aligned (the
    algorithm's original viewport form): the inside test is a comparison and
    crossing points lie exactly on the window edge.  All N pairs are clipped
    at once, in cache-sized blocks; see :func:`_clip_half_plane` for one stage.

    Parameters
    ----------
    subject : array_like (N, K, 2)
        Convex subject polygons [m], counter-clockwise (vehicle 1 outlines).
    clip : array_like (N, 4, 2)
        Outline rectangles [m] in the corner order of :func:`outline_corners`.

    Returns
    -------
    Polygons
        Overlap polygons [m], global frame, K + 4 vertex slots, counter-clockwise.
    """
    return overlap(subject, clip).polygon


class Overlap(NamedTuple):
    """Overlap of N outline pairs (see :func:`overlap`).

    Attributes
    ----------
    polygon : Polygons
        Overlap polygons [m], global frame.
    area : ndarray (N,)
        Overlap area [m^2] (0 where the outlines do not overlap).
    centroid : ndarray (N, 2)
        Centroid of the overlap [m], global frame; NaN where the area is 0.
    """

    polygon: Polygons
    area: np.ndarray
    centroid: np.ndarray


def _clip_block(
    subject: np.ndarray, frame: RectangleFrame
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Clip one block of subject polygons (global (n, K, 2)) by rectangles given by ``frame``.

    Returns the local vertex coordinates x, y (n, K + 4) and the non-empty flag.
    """
    px, py = frame.to_local(subject)
    alive = np.ones(px.shape[0], dtype=bool)
    hl, hw = frame.half_length, frame.half_width
    for axis, sign, bound in ((0, 1.0, hl), (1, 1.0, hw), (0, -1.0, -hl), (1, -1.0, -hw)):
        px, py, left = _clip_half_plane(px, py, axis, sign, bound)
        alive &= left
    return px, py, alive


def _shoelace(px: np.ndarray, py: np.ndarray, nonempty: np.ndarray) -> tuple[np.ndarray, ...]:
    """Area [m^2] and centroid (x, y) [m] of polygons given as vertex arrays (n, W).

    A = 1/2 sum (x_i y_{i+1} - x_{i+1} y_i),
    C = 1/(6A) sum (p_i + p_{i+1}) (x_i y_{i+1} - x_{i+1} y_i)
    (shoelace area and centroid, Nuernberg's formulas, the Momentum Based Impact Model paper ref.
    [27]).
    Coordinates are taken relative to the first vertex against cancellation.
    """
    ox, oy = px[:, 0:1], py[:, 0:1]
    rx, ry = px - ox, py - oy
    nx = np.empty_like(rx)
    ny = np.empty_like(ry)
    nx[:, :-1], nx[:, -1] = rx[:, 1:], rx[:, 0]
    ny[:, :-1], ny[:, -1] = ry[:, 1:], ry[:, 0]
    cross = rx * ny - nx * ry
    twice = cross.sum(axis=1)
    ok = nonempty & (np.abs(twice) > 2.0 * AREA_TOLERANCE)
    with np.errstate(invalid="ignore", divide="ignore"):
        cx = ((rx + nx) * cross).sum(axis=1) / (3.0 * twice) + ox[:, 0]
        cy = ((ry + ny) * cross).sum(axis=1) / (3.0 * twice) + oy[:, 0]
    area = np.where(ok, 0.5 * twice, 0.0)
    return area, np.where(ok, cx, np.nan), np.where(ok, cy, np.nan)


def polygon_area_centroid(polygons: Polygons) -> tuple[np.ndarray, np.ndarray]:
    """Signed area [m^2] and centroid [m] of N polygons (shoelace formula).

    Empty or degenerate polygons (|A| <= :data:`AREA_TOLERANCE`) give area 0
    and a NaN centroid.

    Returns
    -------
    area : ndarray (N,)
        Area [m^2], positive for counter-clockwise polygons.
    centroid : ndarray (N, 2)
        Centroid [m].
    """
    verts, nonempty = polygons
    area, cx, cy = _shoelace(verts[..., 0], verts[..., 1], np.asarray(nonempty, bool))
    return area, np.stack([cx, cy], axis=-1)


def overlap(outline1: npt.ArrayLike, outline2: npt.ArrayLike) -> Overlap:
    """Overlap polygon, area and centroid of N outline pairs.

    Parameters
    ----------
    outline1 : array_like (N, K, 2)
        Convex polygons [m], counter-clockwise (usually outlines, K = 4).
    outline2 : array_like (N, 4, 2)
        Outline rectangles [m] in the corner order of :func:`outline_corners`.

    Returns
    -------
    Overlap
    """
    o1 = np.asarray(outline1, float)
    o2 = np.asarray(outline2, float)
    n, k = o1.shape[:2]
    verts = np.empty((n, k + 4, 2))
    nonempty = np.empty(n, dtype=bool)
    area = np.empty(n)
    centroid = np.empty((n, 2))
    # empty polygons carry NaN coordinates; they are masked, not errors
    with np.errstate(invalid="ignore"):
        for lo in range(0, n, CHUNK):
            hi = min(lo + CHUNK, n)
            frame = rectangle_frame(o2[lo:hi])
            px, py, alive = _clip_block(o1[lo:hi], frame)
            a, cx, cy = _shoelace(px, py, alive)
            verts[lo:hi] = frame.to_global(px, py)
            centroid[lo:hi] = frame.to_global(cx[:, None], cy[:, None])[:, 0]
            area[lo:hi], nonempty[lo:hi] = a, alive
    return Overlap(Polygons(verts, nonempty), area, centroid)


# ----------------------------------------------------------------------------
# Outline intersection points and the contact plane
# ----------------------------------------------------------------------------


def _on_boundary(x: np.ndarray, y: np.ndarray, frame: RectangleFrame) -> np.ndarray:
    """True where local points (n, W) lie on their rectangle's boundary (within tolerance)."""
    gap_x = np.abs(frame.half_length[:, None] - np.abs(x))
    gap_y = np.abs(frame.half_width[:, None] - np.abs(y))
    inside_x = np.abs(x) <= frame.half_length[:, None] + POINT_TOLERANCE
    inside_y = np.abs(y) <= frame.half_width[:, None] + POINT_TOLERANCE
    return ((gap_x <= POINT_TOLERANCE) & inside_y) | ((gap_y <= POINT_TOLERANCE) & inside_x)


def outline_intersections(polygon: Polygons, outline1: np.ndarray,
                          outline2: np.ndarray) -> np.ndarray:
    """Distinct intersection points of two outline boundaries, from their overlap polygon.

    A vertex of the overlap polygon is a corner of outline 1 inside outline 2,
    a corner of outline 2 inside outline 1, or a point where the two
    boundaries cross; the crossing points are exactly the vertices that lie
    on both boundaries.  Touching outlines (zero overlap area) give the
    touching points.

    Parameters
    ----------
    polygon : Polygons
        Overlap polygons (N, W, 2) [m] from :func:`overlap`.
    outline1, outline2 : ndarray (N, 4, 2)
        The two outlines [m].

    Returns
    -------
    ndarray (N, W, 2)
        Intersection points [m]; NaN in slots that hold no (new) point.
    """
    verts, nonempty = polygon
    f1, f2 = rectangle_frame(outline1), rectangle_frame(outline2)
    x1, y1 = f1.to_local(verts)
    x2, y2 = f2.to_local(verts)
    on_both = _on_boundary(x1, y1, f1) & _on_boundary(x2, y2, f2) & nonempty[:, None]
    pts = np.where(on_both[..., None], verts, np.nan)
    w = pts.shape[1]
    diff = pts[:, :, None, :] - pts[:, None, :, :]
    dist = np.sqrt((diff**2).sum(-1))  # NaN where either is absent
    earlier = np.tril(np.ones((w, w), bool), k=-1)[None]
    duplicate = (earlier & (dist <= POINT_TOLERANCE)).any(axis=2)
    return np.where(duplicate[..., None], np.nan, pts)


def contact_plane(
    points: np.ndarray, cg1: np.ndarray, cg2: np.ndarray, area: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Contact-plane tangent angle from the outline intersection points.

    Rules (codes of :data:`CP_RULES`):

    1. Exactly two distinct intersection points: the CP is the line through them (the
       Momentum Based Impact Model paper, section 3.2.1).  This covers one corner
       penetrating an edge (both points lie on that edge) and corner-to-corner overlaps.
    2. More than two points (an outline crossing the other completely, a
       deep penetration): the line through the two points farthest apart,
       i.e. along the widest extent of the contact zone.
    3. No usable pair (one outline contains the other, or the points coincide
       closer than :data:`POINT_TOLERANCE`): the CP is perpendicular to the
       line between the two CGs, the direction in which the bodies push.
    4. Zero overlap area but touching boundaries: along the touching segment
       if it has two distinct points, else rule 3.
    0. No overlap and no touching: NaN.

    Parameters
    ----------
    points : ndarray (N, P, 2)
        Distinct intersection points [m], NaN where absent.
    cg1, cg2 : ndarray (N, 2)
        CG positions [m] (for rule 3).
    area : ndarray (N,)
        Overlap area [m^2].

    Returns
    -------
    cp_angle : ndarray (N,)
        Tangent direction [rad] in [0, pi); NaN without contact.
    n_points : ndarray of int (N,)
        Number of distinct intersection points.
    rule : ndarray of int (N,)
        Rule applied.
    """
    valid = ~np.isnan(points[..., 0])
    n_points = valid.sum(axis=1)
    n, p = valid.shape
    diff = points[:, :, None, :] - points[:, None, :, :]
    dist2 = np.where(valid[:, :, None] & valid[:, None, :], (diff**2).sum(-1), -1.0)
    flat = dist2.reshape(n, p * p)
    best = np.argmax(flat, axis=1)
    i, j = np.divmod(best, p)
    rows = np.arange(n)
    far = np.sqrt(np.maximum(flat[rows, best], 0.0))
    d = points[rows, j] - points[rows, i]
    angle_pts = np.arctan2(d[:, 1], d[:, 0])
    centre = np.asarray(cg2, float) - np.asarray(cg1, float)
    angle_cg = np.arctan2(centre[:, 1], centre[:, 0]) + 0.5 * np.pi
    has_pair = (n_points >= 2) & (far > POINT_TOLERANCE)
    penetrating = area > AREA_TOLERANCE
    touching = ~penetrating & (n_points >= 1)
    rule = np.zeros(n, dtype=np.int64)
    rule = np.where(penetrating & has_pair & (n_points == 2), 1, rule)
    rule = np.where(penetrating & has_pair & (n_points > 2), 2, rule)
    rule = np.where(penetrating & ~has_pair, 3, rule)
    rule = np.where(touching & has_pair, 4, rule)
    rule = np.where(touching & ~has_pair, 3, rule)
    angle = np.where(np.isin(rule, (1, 2, 4)), angle_pts, angle_cg)
    with np.errstate(invalid="ignore"):
        angle = np.where(rule == 0, np.nan, np.mod(angle, np.pi))
        # mod can return pi for tiny negative inputs; keep the half-open interval
        angle = np.where(angle >= np.pi, 0.0, angle)
    return angle, n_points, rule


def contact_geometry(outline1: npt.ArrayLike, outline2: npt.ArrayLike,
                     cg1: npt.ArrayLike, cg2: npt.ArrayLike) -> ContactGeometry:
    """POI and contact plane of N pairs of outlines (the Momentum Based Impact Model paper,
    section 3.2.1).

    The overlap polygon comes from :func:`overlap` (Sutherland-Hodgman), the
    POI is its centroid (for touching outlines the mean of the touching
    points), the contact plane follows :func:`contact_plane`.

    Parameters
    ----------
    outline1, outline2 : array_like (N, 4, 2) or (4, 2)
        Outline corners [m], counter-clockwise (see :func:`outline_corners`).
    cg1, cg2 : array_like (N, 2) or (2,)
        CG positions [m].

    Returns
    -------
    ContactGeometry
    """
    o1 = np.asarray(outline1, float)
    o2 = np.asarray(outline2, float)
    if o1.ndim == 2:
        o1, o2 = o1[None], o2[None]
    c1 = np.atleast_2d(np.asarray(cg1, float))
    c2 = np.atleast_2d(np.asarray(cg2, float))
    ov = overlap(o1, o2)
    points = outline_intersections(ov.polygon, o1, o2)
    cp_angle, n_points, rule = contact_plane(points, c1, c2, ov.area)
    valid = ~np.isnan(points[..., 0])
    with np.errstate(invalid="ignore", divide="ignore"):
        touch_point = np.where(valid[..., None], points, 0.0).sum(axis=1) / n_points[:, None]
    poi = np.where((ov.area > AREA_TOLERANCE)[:, None], ov.centroid, touch_point)
    poi = np.where((rule == 0)[:, None], np.nan, poi)
    return ContactGeometry(ov.polygon, ov.area, poi, cp_angle, n_points, rule)


# ----------------------------------------------------------------------------
# Descriptors of a collision configuration
# ----------------------------------------------------------------------------

#: Codes of :func:`contact_faces`.
FACE_FRONT, FACE_REAR, FACE_LEFT, FACE_RIGHT = 0, 1, 2, 3
FACE_NAMES: dict[int, str] = {FACE_FRONT: "front", FACE_REAR: "rear", FACE_LEFT: "left",
                              FACE_RIGHT: "right"}


def swept_overlap(outline1: npt.ArrayLike, outline2: npt.ArrayLike,
                  direction: npt.ArrayLike) -> np.ndarray:
    """Overlap ratio [-] of two outlines seen along a direction of approach.

    Both outlines (N, K, 2) are projected on the axis perpendicular to ``direction`` (N, 2),
    e.g. the relative velocity v1 - v2; the ratio is the length of the common part of the
    two projections divided by the shorter projection, in [0, 1].  For a head-on or rear-end
    collision this is the usual lateral overlap (width of the engaged front over the vehicle
    width, the Momentum Based Impact Model paper); for a front-to-side collision it is the
    engaged share of the striking front.  NaN where ``direction`` is zero.
    """
    o1 = np.asarray(outline1, float)
    o2 = np.asarray(outline2, float)
    d = np.asarray(direction, float)
    norm = np.hypot(d[:, 0], d[:, 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        px, py = -d[:, 1] / norm, d[:, 0] / norm
    p1 = o1[..., 0] * px[:, None] + o1[..., 1] * py[:, None]
    p2 = o2[..., 0] * px[:, None] + o2[..., 1] * py[:, None]
    lo1, hi1, lo2, hi2 = p1.min(axis=1), p1.max(axis=1), p2.min(axis=1), p2.max(axis=1)
    common = np.maximum(np.minimum(hi1, hi2) - np.maximum(lo1, lo2), 0.0)
    shorter = np.minimum(hi1 - lo1, hi2 - lo2)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(norm > 0.0, np.minimum(common / shorter, 1.0), np.nan)


def contact_faces(points: npt.ArrayLike, vehicles: VehicleArrays, x: npt.ArrayLike,
                  y: npt.ArrayLike, yaw: npt.ArrayLike) -> np.ndarray:
    """Face of each vehicle outline nearest to a point (e.g. the POI).

    The point is expressed in the vehicle frame relative to the outline
    centre; the face is front/rear if |x| / (length / 2) >= |y| / (width / 2),
    else left/right.  Returns codes :data:`FACE_FRONT`, :data:`FACE_REAR`,
    :data:`FACE_LEFT`, :data:`FACE_RIGHT` (N,); NaN points give front.
    """
    local = to_vehicle_frame(points, x, y, yaw)
    centre = 0.5 * (vehicles.cg_to_front - vehicles.cg_to_rear)
    qx, qy = local[:, 0] - centre, local[:, 1]
    ax = np.abs(qx) / (0.5 * vehicles.length)
    ay = np.abs(qy) / (0.5 * vehicles.width)
    end = ~(ay > ax)
    return np.where(end, np.where(~(qx < 0.0), FACE_FRONT, FACE_REAR),
                    np.where(qy >= 0.0, FACE_LEFT, FACE_RIGHT)).astype(np.int64)


# ----------------------------------------------------------------------------
# Distance and first contact of two rectangles
# ----------------------------------------------------------------------------

#: Relative displacements below this [m] count as no relative motion along an axis
#: (:func:`first_contact`).
STILL_DISPLACEMENT = 1e-12


def _corners_to_frame(points: np.ndarray, frame: RectangleFrame) -> np.ndarray:
    """Smallest distance [m] (N,) of the points (N, K, 2) [m] to the rectangles ``frame``.

    A point's distance to a rectangle, in the rectangle's frame:
    sqrt(max(|x| - l/2, 0)^2 + max(|y| - w/2, 0)^2).
    """
    x, y = frame.to_local(points)
    gx = np.maximum(np.abs(x) - frame.half_length[:, None], 0.0)
    gy = np.maximum(np.abs(y) - frame.half_width[:, None], 0.0)
    return np.sqrt(gx * gx + gy * gy).min(axis=1)


def _frames_overlap(a: RectangleFrame, b: RectangleFrame) -> np.ndarray:
    """Separating-axis test (N,) bool: True where rectangles a and b overlap or touch."""
    ca, sa, cb, sb = a.axis[:, 0], a.axis[:, 1], b.axis[:, 0], b.axis[:, 1]
    dx, dy = b.centre[:, 0] - a.centre[:, 0], b.centre[:, 1] - a.centre[:, 1]
    ac, as_ = np.abs(ca * cb + sa * sb), np.abs(ca * sb - sa * cb)  # relative yaw
    return ((np.abs(ca * dx + sa * dy) <= a.half_length + b.half_length * ac
             + b.half_width * as_)
            & (np.abs(-sa * dx + ca * dy) <= a.half_width + b.half_length * as_
               + b.half_width * ac)
            & (np.abs(cb * dx + sb * dy) <= b.half_length + a.half_length * ac
               + a.half_width * as_)
            & (np.abs(-sb * dx + cb * dy) <= b.half_width + a.half_length * as_
               + a.half_width * ac))


def outlines_may_overlap(outline1: npt.ArrayLike, outline2: npt.ArrayLike,
                         margin: float = 0.0) -> np.ndarray:
    """False (N,) where outline rectangles (N, 4, 2) [m] are certainly apart.

    Separating-axis test on the four edge normals with the rectangles grown
    by ``margin`` [m] on every side: where it finds a separating axis the
    outlines are more than 2 ``margin`` apart, so their overlap is empty and
    :func:`overlap` need not be computed (a broad phase for it).  True
    where they overlap, touch or are closer than that.
    """
    a = rectangle_frame(np.asarray(outline1, float))
    b = rectangle_frame(np.asarray(outline2, float))
    grow = lambda f: RectangleFrame(f.centre, f.axis, f.half_length + margin,  # noqa: E731
                                    f.half_width + margin)
    return _frames_overlap(grow(a), grow(b))


def outline_distance(outline1: npt.ArrayLike, outline2: npt.ArrayLike,
                     frame1: RectangleFrame | None = None,
                     frame2: RectangleFrame | None = None) -> np.ndarray:
    """Distance [m] (N,) between outline rectangles given as corners (N, 4, 2) [m].

    The one rectangle-distance kernel of vfs (pre-crash closest approach; the
    gym sensor through :func:`rectangle_distance`).  Overlapping or touching
    rectangles (separating-axis test on the four edge normals) give 0;
    otherwise the distance is the smallest distance of a corner of either
    outline to the other rectangle (the closest points of two disjoint convex
    polygons include a vertex of one of them), each computed in the
    rectangle's frame.  Corners in the order of :func:`outline_corners`;
    ``frame1``, ``frame2`` are their frames when known (else
    :func:`rectangle_frame`).
    """
    o1 = np.asarray(outline1, float)
    o2 = np.asarray(outline2, float)
    a = rectangle_frame(o1) if frame1 is None else frame1
    b = rectangle_frame(o2) if frame2 is None else frame2
    gap = np.minimum(_corners_to_frame(o1, b), _corners_to_frame(o2, a))
    return np.where(_frames_overlap(a, b), 0.0, gap)


_UNIT_CORNERS = (np.array([1.0, 1.0, -1.0, -1.0]), np.array([-1.0, 1.0, 1.0, -1.0]))


def pose_frame(x: npt.ArrayLike, y: npt.ArrayLike, yaw: npt.ArrayLike,
               half_length: npt.ArrayLike, half_width: npt.ArrayLike) -> RectangleFrame:
    """Frame (N,) of rectangles with centre (x, y) [m], long axis at ``yaw`` [rad] and
    half sizes [m].
    """
    x, y, yaw, hl, hw = np.broadcast_arrays(
        *(np.atleast_1d(np.asarray(a, float)) for a in (x, y, yaw, half_length, half_width)))
    return RectangleFrame(np.stack([x, y], axis=-1),
                          np.stack([np.cos(yaw), np.sin(yaw)], axis=-1), hl, hw)


def rectangle_distance(ax: npt.ArrayLike, ay: npt.ArrayLike, ayaw: npt.ArrayLike,
                       ahl: npt.ArrayLike, ahw: npt.ArrayLike, bx: npt.ArrayLike,
                       by: npt.ArrayLike, byaw: npt.ArrayLike, bhl: npt.ArrayLike,
                       bhw: npt.ArrayLike) -> np.ndarray:
    """Distance [m] (N,) between rectangles A and B given by pose; 0 where they overlap.

    Parameters
    ----------
    ax, ay, bx, by : array_like (N,)
        Rectangle centres [m].
    ayaw, byaw : array_like (N,)
        Orientations of the rectangles' long axes [rad].
    ahl, ahw, bhl, bhw : array_like (N,)
        Half lengths and half widths [m].

    Returns
    -------
    ndarray (N,)
        :func:`outline_distance` of the two rectangles [m] (float64).
    """
    a = pose_frame(ax, ay, ayaw, ahl, ahw)
    b = pose_frame(bx, by, byaw, bhl, bhw)
    ux, uy = _UNIT_CORNERS
    corners_a = a.to_global(a.half_length[:, None] * ux, a.half_width[:, None] * uy)
    corners_b = b.to_global(b.half_length[:, None] * ux, b.half_width[:, None] * uy)
    return outline_distance(corners_a, corners_b, a, b)


def first_contact(dx: npt.ArrayLike, dy: npt.ArrayLike, ddx: npt.ArrayLike,
                  ddy: npt.ArrayLike, yaw_a: npt.ArrayLike, hl_a: npt.ArrayLike,
                  hw_a: npt.ArrayLike, yaw_b: npt.ArrayLike, hl_b: npt.ArrayLike,
                  hw_b: npt.ArrayLike) -> np.ndarray:
    """First contact of two rectangles in relative linear motion (swept separating axes).

    Rectangle A (centre at the origin) and rectangle B (centre (dx, dy) [m]
    from A's) keep their orientations; B moves by (ddx, ddy) [m] relative to
    A over the interval, parameterised by s in [0, 1].  On each of the four
    separating axes n (the edge normals of both rectangles) the projections
    overlap while |n.(d + s dd)| <= rho_n (rho_n: sum of the projected half
    extents); the rectangles touch where all four hold, i.e. for s in
    [max_n s_in, min_n s_out] (docs/aeb.md, eq. 3.1).  Exact for translation;
    for two moving rectangles pass the difference of their displacements.

    Parameters
    ----------
    dx, dy : array_like
        Centre of B minus centre of A at s = 0 [m]; any common shape.
    ddx, ddy : array_like
        Displacement of B relative to A over the interval [m].
    yaw_a, yaw_b : array_like
        Orientations [rad].
    hl_a, hw_a, hl_b, hw_b : array_like
        Half lengths and half widths [m].

    Returns
    -------
    ndarray
        First-contact fraction s [-] in [0, 1] of the interval (0 if they
        overlap at the start; the contact time is s times the interval's
        duration, the penetration depth along the motion (1 - s) |dd| when
        they overlap at its end); ``inf`` where they do not touch within the
        interval.
    """
    dx, dy, ddx, ddy = (np.asarray(a) for a in (dx, dy, ddx, ddy))
    yaw_a, yaw_b = np.asarray(yaw_a), np.asarray(yaw_b)
    hl_a, hw_a, hl_b, hw_b = (np.asarray(a) for a in (hl_a, hw_a, hl_b, hw_b))
    ca, sa, cb, sb = np.cos(yaw_a), np.sin(yaw_a), np.cos(yaw_b), np.sin(yaw_b)
    cos_d = np.abs(ca * cb + sa * sb)  # |cos(yaw_a - yaw_b)|
    sin_d = np.abs(sa * cb - ca * sb)  # |sin(yaw_a - yaw_b)|
    # axes: A's x and y, B's x and y; projections of the centre distance,
    # of the relative displacement and the summed projected half extents
    p = np.stack([ca * dx + sa * dy, ca * dy - sa * dx, cb * dx + sb * dy, cb * dy - sb * dx])
    w = np.stack([ca * ddx + sa * ddy, ca * ddy - sa * ddx,
                  cb * ddx + sb * ddy, cb * ddy - sb * ddx])
    rho = np.stack([hl_a + hl_b * cos_d + hw_b * sin_d, hw_a + hl_b * sin_d + hw_b * cos_d,
                    hl_b + hl_a * cos_d + hw_a * sin_d, hw_b + hl_a * sin_d + hw_a * cos_d])
    still = np.abs(w) < STILL_DISPLACEMENT
    w_safe = np.where(still, 1.0, w)
    s1 = (-rho - p) / w_safe  # docs/aeb.md eq. 3.1
    s2 = (rho - p) / w_safe
    inside = np.abs(p) <= rho
    lo = np.where(still, np.where(inside, -np.inf, np.inf), np.minimum(s1, s2))
    hi = np.where(still, np.where(inside, np.inf, -np.inf), np.maximum(s1, s2))
    enter = lo.max(axis=0)
    leave = hi.min(axis=0)
    hit = (enter <= leave) & (enter <= 1.0) & (leave >= 0.0)
    return np.where(hit, np.maximum(enter, 0.0), np.inf)
