"""Contact placement: participant 2's pose at the designed impact (participant 1 at the origin)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from vfs.physics.geometry import outline_corners


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _ray_hits(points: np.ndarray, direction: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """Ray parameters where points + lam * direction cross the polygon edges.

    Parameters
    ----------
    points : ndarray (n, 4, 2)
        Ray origins [m].
    direction : ndarray (n, 2)
        Unit ray direction.
    polygon : ndarray (n, 4, 2)
        Polygon corners [m] (edge j from corner j to corner j + 1).

    Returns
    -------
    ndarray (n, 4, 4)
        lam [m] per (point, edge); inf where the ray misses the edge or runs parallel.
    """
    start = polygon[:, None, :, :]
    edge = np.roll(polygon, -1, axis=1)[:, None, :, :] - start
    d = direction[:, None, None, :]
    r = start - points[:, :, None, :]
    denom = _cross(d, edge)
    ok = np.abs(denom) > 1e-12 * np.hypot(edge[..., 0], edge[..., 1])
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        lam = _cross(r, edge) / denom
        mu = _cross(r, d) / denom
    hit = ok & (mu >= -1e-9) & (mu <= 1.0 + 1e-9)
    return np.where(hit, lam, np.inf)


def slide_to_contact(fixed: np.ndarray, moving: np.ndarray,
                     direction: np.ndarray) -> np.ndarray:
    """Shift along ``direction`` at which ``moving`` first touches ``fixed``.

    ``moving`` translated by lam * direction touches ``fixed`` for lam in an interval;
    its lower end (first contact while moving along +direction) is the smallest lam at
    which a corner of one rectangle lies on an edge of the other: corners of ``moving``
    cast along +direction against the edges of ``fixed`` and corners of ``fixed`` along
    -direction against the edges of ``moving`` (32 ray-segment tests per pair).

    Parameters
    ----------
    fixed, moving : ndarray (n, 4, 2)
        Rectangle corners [m] (any consistent order around the rectangle).
    direction : ndarray (n, 2)
        Unit direction of the relative motion of ``moving``.

    Returns
    -------
    ndarray (n,)
        lam [m] (may be negative); NaN where the rectangles never touch along the line.

    Notes
    -----
    The first-contact kernel of vfs is :func:`vfs.physics.geometry.first_contact`
    (swept separating axes).  It gives the same contacts up to rounding, but not bit for
    bit: placing participant 2 with it moved the x positions of 0.5-1.8 % of the rows
    of ``vfs generate --preset default --seed 0`` in the last digits, and the bundled
    database must stay reproducible, so the scenes keep this ray casting.
    """
    lam = np.concatenate([_ray_hits(moving, direction, fixed).reshape(len(fixed), -1),
                          _ray_hits(fixed, -direction, moving).reshape(len(fixed), -1)],
                         axis=1).min(axis=1)
    return np.where(np.isfinite(lam), lam, np.nan)


class OutlineDims(NamedTuple):
    """Outline of n vehicles relative to the CG [m] (arrays (n,))."""

    front: np.ndarray  # CG to front bumper
    rear: np.ndarray  # CG to rear bumper
    width: np.ndarray

    @property
    def length(self) -> np.ndarray:
        """Overall length (front + rear), m."""
        return self.front + self.rear


def unit_vector(angle: np.ndarray) -> np.ndarray:
    """Unit vectors (cos, sin) (n, 2) of angles [rad] (n,)."""
    return np.stack([np.cos(angle), np.sin(angle)], axis=-1)


def _corners(p: np.ndarray, yaw: np.ndarray, dims: OutlineDims) -> np.ndarray:
    return outline_corners(p[:, 0], p[:, 1], yaw, dims.front, dims.rear, dims.width)


def _rel_direction(yaw1: np.ndarray, v1: np.ndarray, yaw2: np.ndarray,
                   v2: np.ndarray) -> np.ndarray:
    """Unit direction of v2 - v1 (participant 2's motion relative to participant 1)."""
    w = v2[:, None] * unit_vector(yaw2) - v1[:, None] * unit_vector(yaw1)
    return w / np.maximum(np.hypot(w[:, 0], w[:, 1]), 1e-12)[:, None]


def _rect_extent(yaw: np.ndarray, dims: OutlineDims, axis: np.ndarray) -> np.ndarray:
    """Half extent [m] of outline rectangles projected on unit vectors ``axis`` (n, 2)."""
    t, n = unit_vector(yaw), unit_vector(yaw + 0.5 * np.pi)
    return (0.5 * dims.length * np.abs((t * axis).sum(axis=1))
            + 0.5 * dims.width * np.abs((n * axis).sum(axis=1)))


class ImpactPair(NamedTuple):
    """Impact poses and speeds of both participants of n cases (P1 at the origin)."""

    yaw1: np.ndarray  # [rad]
    v1: np.ndarray  # [m/s]
    dims1: OutlineDims
    yaw2: np.ndarray
    v2: np.ndarray
    dims2: OutlineDims


def place_overlap(pair: ImpactPair, face2: float, share: np.ndarray,
                  side: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """CG of participant 2 [m] (participant 1's CG at the origin) for a designed overlap.

    The front of participant 1 and the front (``face2`` = +1) or rear (-1) of participant
    2 overlap by ``share`` of the narrower face width, both projected perpendicular to the
    relative velocity; ``side`` +1 puts participant 2 to participant 1's left.  Then
    participant 2 slides along the relative velocity to first contact.  Returns the
    position and a flag (False where the rectangles can never touch).
    """
    d = _rel_direction(pair.yaw1, pair.v1, pair.yaw2, pair.v2)
    e = np.stack([-d[:, 1], d[:, 0]], axis=1)
    t1, n1 = unit_vector(pair.yaw1), unit_vector(pair.yaw1 + 0.5 * np.pi)
    t2, n2 = unit_vector(pair.yaw2), unit_vector(pair.yaw2 + 0.5 * np.pi)
    h1 = 0.5 * pair.dims1.width * np.abs((n1 * e).sum(axis=1))
    h2 = 0.5 * pair.dims2.width * np.abs((n2 * e).sum(axis=1))
    sep = h1 + h2 - share * 2.0 * np.minimum(h1, h2)
    sgn = side * np.where((n1 * e).sum(axis=1) >= 0.0, 1.0, -1.0)
    face1 = t1 * pair.dims1.front[:, None]
    offset2 = t2 * np.where(face2 > 0, pair.dims2.front, -pair.dims2.rear)[:, None]
    base = face1 + (sgn * sep)[:, None] * e - offset2
    return _slide(pair, base, d)


def place_target(pair: ImpactPair, point1: np.ndarray,
                 point2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """CG of participant 2 [m] aiming its point ``point2`` at participant 1's ``point1``.

    Points are given in the vehicle frames (n, 2) [m]; participant 2 then slides along the
    relative velocity to first contact.
    """
    d = _rel_direction(pair.yaw1, pair.v1, pair.yaw2, pair.v2)
    c1, s1 = np.cos(pair.yaw1), np.sin(pair.yaw1)
    c2, s2 = np.cos(pair.yaw2), np.sin(pair.yaw2)
    target = np.stack([c1 * point1[:, 0] - s1 * point1[:, 1],
                       s1 * point1[:, 0] + c1 * point1[:, 1]], axis=1)
    arm = np.stack([c2 * point2[:, 0] - s2 * point2[:, 1],
                    s2 * point2[:, 0] + c2 * point2[:, 1]], axis=1)
    return _slide(pair, target - arm, d)


def _slide(pair: ImpactPair, base: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n = base.shape[0]
    fixed = _corners(np.zeros((n, 2)), pair.yaw1, pair.dims1)
    moving = _corners(base, pair.yaw2, pair.dims2)
    lam = slide_to_contact(fixed, moving, d)
    ok = np.isfinite(lam)
    return base + np.where(ok, lam, 0.0)[:, None] * d, ok


def place_gap(pair: ImpactPair, gap: np.ndarray, side: np.ndarray) -> np.ndarray:
    """CG of participant 2 [m] for a near miss with lateral ``gap`` [m].

    Perpendicular to the relative velocity the outlines are ``gap`` apart (participant 2
    on participant 1's left for ``side`` +1); along it they are about to pass each other
    (the projections just start to overlap), so that with straight relative motion the
    outlines pass at exactly ``gap``.
    """
    d = _rel_direction(pair.yaw1, pair.v1, pair.yaw2, pair.v2)
    e = np.stack([-d[:, 1], d[:, 0]], axis=1)
    t1, n1 = unit_vector(pair.yaw1), unit_vector(pair.yaw1 + 0.5 * np.pi)
    t2 = unit_vector(pair.yaw2)
    centre1 = t1 * (0.5 * (pair.dims1.front - pair.dims1.rear))[:, None]
    h = _rect_extent(pair.yaw1, pair.dims1, e) + _rect_extent(pair.yaw2, pair.dims2, e)
    k = _rect_extent(pair.yaw1, pair.dims1, d) + _rect_extent(pair.yaw2, pair.dims2, d)
    sgn = side * np.where((n1 * e).sum(axis=1) >= 0.0, 1.0, -1.0)
    centre2 = centre1 + (sgn * (h + gap))[:, None] * e - k[:, None] * d
    return centre2 - t2 * (0.5 * (pair.dims2.front - pair.dims2.rear))[:, None]
