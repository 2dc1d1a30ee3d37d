"""OpenDRIVE roads for exported cases: reference lines fitted to recorded paths.

A case's road is one or two roads of two driving lanes (one per direction,
:data:`LANE_WIDTH` wide each, the reference line between them, right-hand
traffic).  Each road's reference line is a :class:`ReferenceLine`: a start
pose and a sequence of OpenDRIVE geometries (line, arc, spiral) whose
curvature is continuous and piecewise linear in the arc length.  Two ways to
build one:

* :func:`straight_reference` -- a line along a vehicle's initial heading;
* :func:`fit_reference_line` -- a clothoid spline fitted by least squares to
  ordered points (the recorded path shifted half a lane to the driver's left,
  so that the vehicle drives in the middle of its lane), simplified into
  lines, arcs and spirals.

:func:`case_roads` chooses per case (:func:`case_roads` documents the rule);
:func:`opendrive_document` writes the roads with ``scenariogeneration``
(optional extra ``xosc``); :func:`read_opendrive` reads the subset back
(line, arc and spiral geometries, lane friction).

Units: m, rad, 1/m.
"""

from __future__ import annotations

import datetime as _dt
import math
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
import numpy.typing as npt

from vfs.errors import DataError, DataProblem, ParameterError
from vfs.units import wrap_angle

__all__ = [
    "KNOT_SPACING",
    "LANE_WIDTH",
    "MAX_ROAD_CURVATURE",
    "ROAD_MARGIN",
    "ROAD_MODES",
    "CaseRoads",
    "ReferenceLine",
    "Road",
    "RoadSegment",
    "case_roads",
    "fit_reference_line",
    "opendrive_document",
    "read_opendrive",
    "reference_points",
    "road_curvature_at",
    "straight_reference",
]

#: Width of each of the two lanes [m] (a rural two-lane road).
LANE_WIDTH = 3.5
#: Road length added before the first and after the last point a road carries [m].
ROAD_MARGIN = 20.0
#: Spacing of the curvature knots of a fitted reference line [m].
KNOT_SPACING = 10.0
#: Largest curvature of a fitted reference line [1/m] (the schema's road_curvature range).
MAX_ROAD_CURVATURE = 0.2
#: Curvatures below this [1/m] make a geometry a line; curvature changes below it an arc
#: (over a 10 m piece a heading change of at most 5 mrad).
CURVATURE_RESOLUTION = 5e-4
#: Weight of the distance along the line from a point's station in the fit [-].
ALONG_WEIGHT = 0.1
#: Weights of the curvature's second differences in the fit, per knot spacing squared [-]
#: (with 100, a second difference of 1e-3 1/m between 10 m pieces costs like a lateral miss
#: of 10 m; with 0.1 like 1 cm), tried from the smoothest: the next is taken only while it
#: brings the largest lateral distance below LADDER_GAIN times the previous one.  A
#: vehicle's drift across its lane (its points leave any smooth road) then stays in the
#: trajectory, while a road that really bends sharply is followed.
SMOOTHNESS_LADDER: tuple[float, ...] = (100.0, 10.0, 1.0, 0.1)
#: See SMOOTHNESS_LADDER [-].
LADDER_GAIN = 0.7
#: How ``case_roads`` builds the road: see :func:`case_roads`.
ROAD_MODES: tuple[str, ...] = ("auto", "straight", "path")
#: A point is on a road (Road.contains) while at most this far outside its lanes [m].
ON_ROAD_TOLERANCE = 0.5
#: Two vehicles drive on the same road when their headings at the closest approach differ
#: by less than this from parallel or anti-parallel [rad].
SAME_ROAD_ANGLE = math.radians(30.0)

_GAUSS_NODES, _GAUSS_WEIGHTS = np.polynomial.legendre.leggauss(6)


@dataclass(frozen=True)
class RoadSegment:
    """One OpenDRIVE geometry of a reference line.

    Attributes
    ----------
    kind : {"line", "arc", "spiral"}
        OpenDRIVE geometry element.
    length : float
        Arc length [m], > 0.
    curvature_start, curvature_end : float
        Curvature at its start and end [1/m] (positive = turning left); equal
        for an arc, both zero for a line.
    """

    kind: Literal["line", "arc", "spiral"]
    length: float
    curvature_start: float = 0.0
    curvature_end: float = 0.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.length) and self.length > 0):
            raise ParameterError(f"road geometry length={self.length} m must be > 0")


def _heading_and_position(x0: float, y0: float, h0: float, k0: float, k1: float,
                          length: float, u: np.ndarray) -> tuple[np.ndarray, ...]:
    """Pose at arc lengths ``u`` (sorted, in [0, length]) of a geometry with curvature
    varying linearly from ``k0`` to ``k1`` [1/m] over ``length`` [m] (exact to ~1e-12 m:
    6-point Gauss-Legendre on pieces of at most 1 m).
    """
    rate = (k1 - k0) / length

    def theta(v: np.ndarray) -> np.ndarray:
        return h0 + k0 * v + 0.5 * rate * v * v

    grid = np.union1d(u, np.linspace(0.0, length, max(2, int(math.ceil(length)) + 1)))
    a, b = grid[:-1], grid[1:]
    half = 0.5 * (b - a)
    nodes = 0.5 * (a + b)[:, None] + half[:, None] * _GAUSS_NODES[None, :]
    th = theta(nodes)
    dx = (np.cos(th) * _GAUSS_WEIGHTS).sum(axis=1) * half
    dy = (np.sin(th) * _GAUSS_WEIGHTS).sum(axis=1) * half
    gx = x0 + np.concatenate([[0.0], np.cumsum(dx)])
    gy = y0 + np.concatenate([[0.0], np.cumsum(dy)])
    idx = np.searchsorted(grid, u)
    return gx[idx], gy[idx], theta(u), k0 + rate * u


@dataclass(frozen=True)
class ReferenceLine:
    """A road's reference line: start pose and geometries (OpenDRIVE planView).

    Attributes
    ----------
    x, y : float
        Start point [m], global frame.
    heading : float
        Start heading [rad], counter-clockwise from the x axis.
    segments : tuple of RoadSegment
        The geometries in order; curvature may jump between them, position
        and heading do not.
    """

    x: float
    y: float
    heading: float
    segments: tuple[RoadSegment, ...]

    def __post_init__(self) -> None:
        if not self.segments:
            raise ParameterError("a reference line needs at least one geometry")

    @property
    def length(self) -> float:
        """Total length [m]."""
        return float(sum(seg.length for seg in self.segments))

    def starts(self) -> list[tuple[float, float, float, float]]:
        """Start ``(s, x, y, heading)`` of every geometry [m, m, m, rad]."""
        out = []
        s, x, y, h = 0.0, self.x, self.y, self.heading
        for seg in self.segments:
            out.append((s, x, y, h))
            ex, ey, eh, _ = _heading_and_position(x, y, h, seg.curvature_start,
                                                  seg.curvature_end, seg.length,
                                                  np.array([seg.length]))
            s, x, y, h = s + seg.length, float(ex[0]), float(ey[0]), float(eh[0])
        return out

    def evaluate(self, s: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Position, heading and curvature at stations ``s`` [m] (clipped to the line).

        Returns
        -------
        x, y : ndarray
            Reference-line points [m].
        heading : ndarray
            Tangent direction [rad].
        curvature : ndarray
            [1/m]
        """
        s_arr = np.clip(np.asarray(s, dtype=float).reshape(-1), 0.0, self.length)
        out = [np.empty_like(s_arr) for _ in range(4)]
        bounds = np.cumsum([0.0] + [seg.length for seg in self.segments])
        which = np.clip(np.searchsorted(bounds, s_arr, side="right") - 1, 0,
                        len(self.segments) - 1)
        for k, (seg, (s0, x0, y0, h0)) in enumerate(zip(self.segments, self.starts(),
                                                        strict=True)):
            rows = np.flatnonzero(which == k)
            if rows.size == 0:
                continue
            u = np.clip(s_arr[rows] - s0, 0.0, seg.length)
            order = np.argsort(u, kind="stable")
            vals = _heading_and_position(x0, y0, h0, seg.curvature_start, seg.curvature_end,
                                         seg.length, u[order])
            for arr, v in zip(out, vals, strict=True):
                arr[rows[order]] = v
        return out[0], out[1], out[2], out[3]

    def sample(self, step: float = 0.5) -> tuple[np.ndarray, ...]:
        """Stations every ``step`` [m] (and the end) with :meth:`evaluate`'s values."""
        s = np.union1d(np.arange(0.0, self.length, step), [self.length])
        return (s, *self.evaluate(s))

    def project(self, points: npt.ArrayLike, step: float = 0.25
                ) -> tuple[np.ndarray, np.ndarray]:
        """Station and signed lateral offset (left of the line positive) of points.

        Parameters
        ----------
        points : array_like (n, 2)
            [m]
        step : float
            Sampling of the line for the nearest-point search [m]; the offset
            is measured from the tangent at the nearest sample (exact to
            ~ curvature * step^2).

        Returns
        -------
        s, t : ndarray (n,)
            [m]; points beyond the ends project onto the end tangents (s
            outside [0, length]).
        """
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        s, x, y, h, _ = self.sample(step)
        return _project(p, s, x, y, h)


def _project(p: np.ndarray, s: np.ndarray, x: np.ndarray, y: np.ndarray,
             h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Station and lateral offset of points ``p`` on a sampled curve."""
    d2 = (p[:, 0, None] - x[None, :]) ** 2 + (p[:, 1, None] - y[None, :]) ** 2
    k = np.argmin(d2, axis=1)
    dx, dy = p[:, 0] - x[k], p[:, 1] - y[k]
    c, sn = np.cos(h[k]), np.sin(h[k])
    along = dx * c + dy * sn
    return s[k] + along, -dx * sn + dy * c


@dataclass(frozen=True)
class Road:
    """One road of an exported case.

    Attributes
    ----------
    road_id : int
        OpenDRIVE road id (1, 2).
    reference : ReferenceLine
    lane_width : float
        Width of each of the two lanes [m].
    friction : float
        Tyre-road friction coefficient of the lanes [-] (OpenDRIVE lane material).
    name : str
        Free text.
    """

    road_id: int
    reference: ReferenceLine
    lane_width: float = LANE_WIDTH
    friction: float = 0.8
    name: str = ""

    def contains(self, points: npt.ArrayLike, tolerance: float = ON_ROAD_TOLERANCE) -> bool:
        """True if every point [m] lies on the road (its lanes, up to ``tolerance`` [m])."""
        s, t = self.reference.project(points)
        return bool(np.all(np.abs(t) <= self.lane_width + tolerance)
                    and np.all(s >= -tolerance)
                    and np.all(s <= self.reference.length + tolerance))


@dataclass(frozen=True)
class CaseRoads:
    """The road network of one exported case.

    Attributes
    ----------
    roads : tuple of Road
        Road 1 carries participant 1; road 2 exists when participant 2 does
        not drive on road 1 (e.g. crossing paths).
    mode : {"straight", "path"}
        How the reference lines were built.
    fit_error : float
        Largest lateral distance [m] between a fitted reference line and the
        points it was fitted to (0 for straight roads).
    """

    roads: tuple[Road, ...]
    mode: str
    fit_error: float = 0.0
    notes: tuple[str, ...] = field(default=())


# ----------------------------------------------------------------------------
# Building reference lines
# ----------------------------------------------------------------------------


def reference_points(x: npt.ArrayLike, y: npt.ArrayLike, yaw: npt.ArrayLike,
                     lane_width: float = LANE_WIDTH) -> np.ndarray:
    """Points of the road's reference line for a vehicle driving in the middle of its lane.

    The vehicle keeps right: the reference line (between the two lanes) lies
    half a lane to the left of its CG, whichever direction it drives.

    Parameters
    ----------
    x, y : array_like (n,)
        CG positions [m].
    yaw : array_like (n,)
        Vehicle yaw [rad].
    lane_width : float
        [m]

    Returns
    -------
    ndarray (n, 2)
        [m]
    """
    yaw_a = np.asarray(yaw, dtype=float)
    half = 0.5 * lane_width
    return np.stack([np.asarray(x, float) - half * np.sin(yaw_a),
                     np.asarray(y, float) + half * np.cos(yaw_a)], axis=1)


def straight_reference(x0: float, y0: float, heading: float, points: npt.ArrayLike,
                       margin: float = ROAD_MARGIN) -> ReferenceLine:
    """A straight reference line through ``(x0, y0)`` along ``heading`` that covers the
    projections of ``points`` with ``margin`` [m] to spare at both ends.

    Parameters
    ----------
    x0, y0 : float
        A point of the line [m].
    heading : float
        Direction [rad].
    points : array_like (n, 2)
        Points [m] the road must reach.
    margin : float
        [m]
    """
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    c, s = math.cos(heading), math.sin(heading)
    along = (p[:, 0] - x0) * c + (p[:, 1] - y0) * s
    lo = float(min(along.min(initial=0.0), 0.0)) - margin
    hi = float(max(along.max(initial=0.0), 0.0)) + margin
    return ReferenceLine(x0 + lo * c, y0 + lo * s, float(heading),
                         (RoadSegment("line", hi - lo),))


def _thin(points: np.ndarray, spacing: float) -> np.ndarray:
    """Ordered points with consecutive points at least ``spacing`` [m] apart (ends kept)."""
    keep = [0]
    last = points[0]
    for i in range(1, len(points)):
        if math.hypot(*(points[i] - last)) >= spacing:
            keep.append(i)
            last = points[i]
    if keep[-1] != len(points) - 1 and len(keep) > 1:
        keep[-1] = len(points) - 1
    elif keep[-1] != len(points) - 1:
        keep.append(len(points) - 1)
    return points[keep]


def _spline_pose(params: np.ndarray, knots: np.ndarray, s: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions and headings at stations ``s`` (regular grid from 0) of the clothoid
    spline ``params`` = (x0, y0, h0, curvature at the knots).
    """
    x0, y0, h0 = params[:3]
    kappa = np.interp(s, knots, params[3:])
    ds = np.diff(s)
    theta = h0 + np.concatenate([[0.0], np.cumsum(0.5 * (kappa[1:] + kappa[:-1]) * ds)])
    # Simpson on each step with the exact mid-step heading (kappa linear between samples)
    k_mid = 0.5 * (kappa[1:] + kappa[:-1])
    th_mid = theta[:-1] + 0.5 * ds * (kappa[:-1] + 0.5 * (k_mid - kappa[:-1]))
    cx = ds / 6.0 * (np.cos(theta[:-1]) + 4 * np.cos(th_mid) + np.cos(theta[1:]))
    cy = ds / 6.0 * (np.sin(theta[:-1]) + 4 * np.sin(th_mid) + np.sin(theta[1:]))
    return (x0 + np.concatenate([[0.0], np.cumsum(cx)]),
            y0 + np.concatenate([[0.0], np.cumsum(cy)]), theta)


def _segments_from_knots(knots: np.ndarray, kappa: np.ndarray) -> tuple[RoadSegment, ...]:
    """Lines, arcs and spirals from a piecewise-linear curvature.

    A piece with both end curvatures below :data:`CURVATURE_RESOLUTION` is a
    line, one whose curvature changes by less than that an arc of the mean
    curvature (the same heading change), the others are spirals; neighbouring
    lines, and neighbouring arcs whose curvatures differ by less than the
    resolution, are merged (length-weighted mean curvature).
    """
    out: list[RoadSegment] = []
    for a, b, ka, kb in zip(knots[:-1], knots[1:], kappa[:-1], kappa[1:], strict=True):
        length = float(b - a)
        if max(abs(ka), abs(kb)) < CURVATURE_RESOLUTION:
            seg = RoadSegment("line", length)
        elif abs(ka - kb) < CURVATURE_RESOLUTION:
            k = float(0.5 * (ka + kb))
            seg = RoadSegment("arc", length, k, k)
        else:
            seg = RoadSegment("spiral", length, float(ka), float(kb))
        prev = out[-1] if out else None
        if prev is not None and prev.kind == seg.kind == "line":
            out[-1] = RoadSegment("line", prev.length + length)
        elif prev is not None and prev.kind == seg.kind == "arc" and \
                abs(prev.curvature_start - seg.curvature_start) < CURVATURE_RESOLUTION:
            total = prev.length + length
            k = (prev.curvature_start * prev.length + seg.curvature_start * length) / total
            out[-1] = RoadSegment("arc", total, k, k)
        else:
            out.append(seg)
    return tuple(out)


def _spline_residuals(params: np.ndarray, knots: np.ndarray, grid: np.ndarray,
                      p: np.ndarray, u: np.ndarray, smooth: float) -> np.ndarray:
    """Lateral and (weighted) longitudinal distances of the points from their stations
    ``u`` on the spline, and the smoothness penalty.
    """
    x, y, h = _spline_pose(params, knots, grid)
    cx, cy, ch = np.interp(u, grid, x), np.interp(u, grid, y), np.interp(u, grid, h)
    dx, dy = p[:, 0] - cx, p[:, 1] - cy
    c, s = np.cos(ch), np.sin(ch)
    k = params[3:]
    rough = smooth * np.diff(k, 2) if k.size > 2 else np.zeros(0)
    return np.concatenate([-dx * s + dy * c, ALONG_WEIGHT * (dx * c + dy * s), rough])


def fit_reference_line(points: npt.ArrayLike, *, knot_spacing: float = KNOT_SPACING,
                       margin: float = ROAD_MARGIN,
                       max_curvature: float = MAX_ROAD_CURVATURE
                       ) -> tuple[ReferenceLine, float]:
    """Fit a reference line (lines, arcs, spirals) to ordered points.

    The curvature is piecewise linear in the arc length with knots every
    about ``knot_spacing`` (a clothoid spline).  Start pose and knot
    curvatures minimise, by least squares, the lateral distances of the
    points from the line (plus a small weight on the distance along it from
    each point's station, the chord length, re-estimated once) and a
    penalty on the knots' second differences (smoothness; it also continues
    the curvature over the ``margin`` beyond the points), with the weights
    of :data:`SMOOTHNESS_LADDER` (Levenberg-Marquardt); curvatures are then
    clipped to ``max_curvature``.  The spline is written as OpenDRIVE
    geometries (:func:`_segments_from_knots`) and its start pose refitted.

    Parameters
    ----------
    points : array_like (n, 2)
        Points along the road in driving order [m] (:func:`reference_points`).
    knot_spacing : float
        [m]
    margin : float
        Road length before the first and after the last point [m].
    max_curvature : float
        [1/m]

    Returns
    -------
    reference : ReferenceLine
    error : float
        Largest lateral distance of a point from the final reference line [m].

    Raises
    ------
    ParameterError
        Fewer than two finite points or a path shorter than 1 m.
    """
    from scipy.optimize import least_squares

    p = np.asarray(points, dtype=float).reshape(-1, 2)
    if p.shape[0] < 2 or not np.isfinite(p).all():
        raise ParameterError("fitting a road needs at least two finite points")
    p = _thin(p, 1.0)
    chord = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(p, axis=0).T))])
    if chord[-1] < 1.0:
        raise ParameterError(f"the path is {chord[-1]:.2f} m long; a fitted road needs 1 m")
    total = chord[-1] + 2 * margin
    n_pieces = max(1, int(math.ceil(total / knot_spacing)))
    knots = np.linspace(0.0, total, n_pieces + 1)
    grid = np.union1d(np.arange(0.0, total, 0.5), [total])
    # initial guess: headings of chords about 5 m long, differentiated and smoothed
    ahead = np.searchsorted(chord, np.minimum(chord + 5.0, chord[-1]))
    ahead = np.maximum(ahead, np.arange(len(p)) + 1).clip(max=len(p) - 1)
    base = np.minimum(np.arange(len(p)), len(p) - 2)
    d = p[ahead] - p[base]
    heading = np.unwrap(np.arctan2(d[:, 1], d[:, 0]))
    h0 = float(heading[0])
    u = chord + margin
    kappa0 = np.gradient(heading, u) if len(p) > 2 else np.zeros(len(p))
    kappa0 = np.clip(np.nan_to_num(np.interp(knots, u, kappa0)), -max_curvature, max_curvature)
    start = p[0] - margin * np.array([math.cos(h0), math.sin(h0)])
    params = np.concatenate([[start[0], start[1], h0], kappa0])
    u_start, best, best_error = u, params, math.inf
    for weight in SMOOTHNESS_LADDER:  # less smoothing only while it pays
        u, trial = u_start, best
        for _ in range(2):  # fit, re-estimate the stations, fit again
            trial = least_squares(_spline_residuals, trial, method="lm", x_scale="jac",
                                  max_nfev=2000,
                                  args=(knots, grid, p, u, weight * knot_spacing ** 2)).x
            trial[3:] = np.clip(trial[3:], -max_curvature, max_curvature)
            x, y, h = _spline_pose(trial, knots, grid)
            u, lateral = _project(p, grid, x, y, h)
            u = np.clip(u, 0.0, total)
        error = float(np.max(np.abs(lateral)))
        if error > LADDER_GAIN * best_error:
            break
        best, best_error = trial, error
    params = best
    segments = _segments_from_knots(knots, params[3:])

    def pose_residuals(pose: np.ndarray) -> np.ndarray:
        line = ReferenceLine(float(pose[0]), float(pose[1]), float(pose[2]), segments)
        return line.project(p, step=0.5)[1]

    pose = least_squares(pose_residuals, params[:3], method="lm", x_scale="jac",
                         max_nfev=200).x
    ref = ReferenceLine(float(pose[0]), float(pose[1]), float(pose[2]), segments)
    error = float(np.max(np.abs(ref.project(p)[1])))
    return ref, error


# ----------------------------------------------------------------------------
# The roads of a case
# ----------------------------------------------------------------------------


@dataclass(frozen=True)
class _Path:
    """One vehicle's CG path [m, rad]."""

    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray

    @property
    def xy(self) -> np.ndarray:
        return np.stack([self.x, self.y], axis=1)

    def length(self) -> float:
        return float(np.hypot(np.diff(self.x), np.diff(self.y)).sum())


def _same_road(a: _Path, b: _Path) -> bool:
    """Paths roughly parallel or anti-parallel at their starts or where they come closest."""
    d2 = (a.x[:, None] - b.x[None, :]) ** 2 + (a.y[:, None] - b.y[None, :]) ** 2
    i, j = np.unravel_index(int(np.argmin(d2)), d2.shape)
    limit = math.sin(SAME_ROAD_ANGLE)
    return any(abs(math.sin(float(wrap_angle(a.yaw[k] - b.yaw[m])))) < limit
               for k, m in ((0, 0), (i, j)))


def _road_heading(yaws: np.ndarray, heading: float) -> float:
    """Direction [rad] of a straight road from the yaw angles of the vehicles on it: their
    median, taken modulo pi (oncoming vehicles count too) around ``heading``; robust to
    drifts, lane changes and turns, which occupy a minority of the samples.
    """
    offsets = np.asarray(wrap_angle(2.0 * (np.asarray(yaws, float) - heading))) / 2.0
    return heading + float(np.median(offsets))


def _merged_points(ego: _Path, other: _Path, lane_width: float) -> np.ndarray:
    """Reference points of the ego, extended by the other vehicle's beyond both ends of
    the ego's path (ordered along the ego's direction).
    """
    pe = reference_points(ego.x, ego.y, ego.yaw, lane_width)
    po = reference_points(other.x, other.y, other.yaw, lane_width)
    parts = [pe]
    for end, sign in ((0, -1.0), (-1, 1.0)):
        direction = np.array([math.cos(ego.yaw[end]), math.sin(ego.yaw[end])])
        along = (po - pe[end]) @ direction * sign
        beyond = along > 1.0
        if beyond.any():
            order = np.argsort(along[beyond] * sign)
            extra = po[beyond][order]
            parts.insert(0 if sign < 0 else len(parts), extra)
    return np.concatenate(parts)


def case_roads(x1: npt.ArrayLike, y1: npt.ArrayLike, yaw1: npt.ArrayLike,
               x2: npt.ArrayLike, y2: npt.ArrayLike, yaw2: npt.ArrayLike, *,
               road_curvature: float = 0.0, mode: str = "auto",
               lane_width: float = LANE_WIDTH, friction: float = 0.8,
               margin: float = ROAD_MARGIN) -> CaseRoads:
    """The roads of one case from the CG paths of its two vehicles.

    Road 1 carries participant 1 (the ego), which starts in the middle of
    the right lane (exactly on a straight road, approximately on a fitted
    one).  ``mode``:

    * ``"straight"``: a straight road in the median direction of the
      vehicles it carries (:func:`_road_heading`), placed so that the ego
      starts in the middle of its right lane;
    * ``"path"``: the reference line fitted to the ego's reference points
      (:func:`fit_reference_line`), continued along participant 2's beyond
      the ends of the ego's path;
    * ``"auto"`` (default): ``"straight"`` when the case's road curvature is
      0, else ``"path"``.

    Both vehicles share road 1 when they drive on the same road: their
    headings at the start or at the closest approach within 30 degrees of
    parallel or anti-parallel (oncoming, rear-end, overtaking, a left turn
    across oncoming traffic); a vehicle may leave the lanes (drift, evasive
    swerve, turning off).  Otherwise (crossing paths) participant 2 gets a
    road 2 of its own, built the same way along its path (the roads overlap;
    no junction is modelled).  Roads reach :data:`ROAD_MARGIN` beyond every
    point they carry.

    Parameters
    ----------
    x1, y1, yaw1, x2, y2, yaw2 : array_like
        CG paths [m] and yaw angles [rad] of participants 1 and 2.
    road_curvature : float
        The case's road curvature at the collision [1/m] (``cases`` table).
    mode : {"auto", "straight", "path"}
    lane_width : float
        [m]
    friction : float
        Lane friction coefficient [-].
    margin : float
        [m]

    Returns
    -------
    CaseRoads
    """
    if mode not in ROAD_MODES:
        raise ParameterError(f"road mode {mode!r}; use one of {', '.join(ROAD_MODES)}")
    if not (math.isfinite(lane_width) and 2.0 <= lane_width <= 6.0):
        raise ParameterError(f"lane width {lane_width} m outside [2, 6] m")
    ego = _Path(*(np.asarray(v, float) for v in (x1, y1, yaw1)))
    other = _Path(*(np.asarray(v, float) for v in (x2, y2, yaw2)))
    chosen = ("straight" if road_curvature == 0 else "path") if mode == "auto" else mode
    notes: list[str] = []
    if chosen == "path" and ego.length() < 1.0:
        chosen = "straight"
        notes.append("participant 1 hardly moves: straight road")

    def build(path: _Path, extra: _Path | None) -> tuple[ReferenceLine, float]:
        if chosen == "straight" or path.length() < 1.0:
            start = reference_points(path.x[:1], path.y[:1], path.yaw[:1], lane_width)[0]
            cg, yaws = path.xy, path.yaw
            if extra is not None:
                cg = np.concatenate([cg, extra.xy])
                yaws = np.concatenate([yaws, extra.yaw])
            heading = _road_heading(yaws, float(path.yaw[0]))
            return straight_reference(float(start[0]), float(start[1]), heading, cg,
                                      margin), 0.0
        pts = reference_points(path.x, path.y, path.yaw, lane_width) if extra is None \
            else _merged_points(path, extra, lane_width)
        return fit_reference_line(pts, margin=margin)

    if _same_road(ego, other):
        ref1, err1 = build(ego, other)
        return CaseRoads((Road(1, ref1, lane_width, friction, "road of both participants"),),
                         chosen, err1, tuple(notes))
    ref1, err1 = build(ego, None)
    ref2, err2 = build(other, None)
    notes.append("participant 2 crosses road 1: it has a road of its own (no junction)")
    return CaseRoads((Road(1, ref1, lane_width, friction, "road of participant 1"),
                      Road(2, ref2, lane_width, friction, "road of participant 2")),
                     chosen, max(err1, err2), tuple(notes))


# ----------------------------------------------------------------------------
# Writing and reading OpenDRIVE
# ----------------------------------------------------------------------------


def opendrive_document(roads: CaseRoads, name: str) -> ET.Element:
    """The OpenDRIVE 1.7 document of a case's roads (``scenariogeneration``).

    Each road: the planView geometries of its reference line, one lane
    section with a driving lane on each side (id 1 left, -1 right) of
    constant width and the case's friction as lane material; no road marks,
    no junctions.  The header's bounds enclose the reference lines.

    Parameters
    ----------
    roads : CaseRoads
    name : str
        Header name.

    Returns
    -------
    xml.etree.ElementTree.Element
        The ``OpenDRIVE`` root element.
    """
    from vfs.interop.extra import require_extra

    xodr = require_extra("scenariogeneration.xodr")
    odr = xodr.OpenDrive(name, revMajor="1", revMinor="7")
    xs: list[float] = []
    ys: list[float] = []
    for road in roads.roads:
        ref = road.reference
        plan = xodr.PlanView()
        for seg, (s0, x0, y0, h0) in zip(ref.segments, ref.starts(), strict=True):
            if seg.kind == "line":
                geom = xodr.Line(seg.length)
            elif seg.kind == "arc":
                geom = xodr.Arc(seg.curvature_start, length=seg.length)
            else:
                geom = xodr.Spiral(seg.curvature_start, seg.curvature_end, length=seg.length)
            plan.add_fixed_geometry(geom, x0, y0, h0, s=s0)
        centre = xodr.Lane(a=0)
        section = xodr.LaneSection(0, centre)
        for add in (section.add_left_lane, section.add_right_lane):
            lane = xodr.Lane(xodr.LaneType.driving, a=road.lane_width)
            lane.add_lane_material(float(road.friction))
            add(lane)
        lanes = xodr.Lanes()
        lanes.add_lanesection(section)
        odr.add_road(xodr.Road(road.road_id, plan, lanes, name=road.name))
        _, x, y, _, _ = ref.sample(5.0)
        xs += [float(x.min()), float(x.max())]
        ys += [float(y.min()), float(y.max())]
    root: ET.Element = odr.get_element()
    header = root.find("header")
    if header is not None:
        pad = 2 * max(r.lane_width for r in roads.roads)
        header.set("north", repr(max(ys) + pad))
        header.set("south", repr(min(ys) - pad))
        header.set("east", repr(max(xs) + pad))
        header.set("west", repr(min(xs) - pad))
        header.set("date", _dt.datetime.now().replace(microsecond=0).isoformat())
    return root


def _float(element: ET.Element, name: str, where: str) -> float:
    text = element.get(name)
    try:
        return float(text)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise DataError(DataProblem(where, name, None, None,
                                    f"attribute {name}={text!r} is not a number")) from None


def read_opendrive(path: str | Path) -> list[Road]:
    """The roads of an OpenDRIVE file, as far as vfs uses them.

    Reads each road's planView (line, arc and spiral geometries; a road with
    other geometries such as paramPoly3 is skipped), the width of its first
    lanes and the friction of the first lane material found (default 0.8).

    Parameters
    ----------
    path : path
        ``.xodr`` file.

    Returns
    -------
    list of Road

    Raises
    ------
    DataError
        Unreadable file or malformed numbers.
    """
    where = Path(path).name
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as exc:
        raise DataError(DataProblem(where, "", None, None,
                                    f"cannot read OpenDRIVE file: {exc}")) from None
    roads: list[Road] = []
    for road in root.iter("road"):
        geoms = road.findall("planView/geometry")
        segments: list[RoadSegment] = []
        start: tuple[float, float, float] | None = None
        supported = bool(geoms)
        for g in geoms:
            length = _float(g, "length", where)
            if start is None:
                start = (_float(g, "x", where), _float(g, "y", where), _float(g, "hdg", where))
            kind = g[0].tag if len(g) else ""
            if kind == "line":
                segments.append(RoadSegment("line", length))
            elif kind == "arc":
                k = _float(g[0], "curvature", where)
                segments.append(RoadSegment("arc", length, k, k))
            elif kind == "spiral":
                segments.append(RoadSegment("spiral", length, _float(g[0], "curvStart", where),
                                            _float(g[0], "curvEnd", where)))
            else:
                supported = False
                break
        if not supported or start is None:
            continue
        width = LANE_WIDTH
        w = road.find("lanes/laneSection/right/lane/width")
        if w is None:
            w = road.find("lanes/laneSection/left/lane/width")
        if w is not None:
            width = _float(w, "a", where)
        friction = 0.8
        m = road.find("lanes/laneSection//lane/material")
        if m is not None and m.get("friction") is not None:
            friction = _float(m, "friction", where)
        try:
            rid = int(road.get("id", "0"))
        except ValueError:
            rid = len(roads) + 1
        roads.append(Road(rid, ReferenceLine(*start, tuple(segments)), width, friction,
                          road.get("name", "")))
    return roads


def road_curvature_at(roads: Sequence[Road], x: float, y: float) -> float:
    """Curvature [1/m] of the nearest road's reference line at the point (x, y) [m];
    0 without roads.
    """
    best: tuple[float, float] | None = None
    for road in roads:
        s, t = road.reference.project([[x, y]])
        k = float(road.reference.evaluate(s)[3][0])
        if best is None or abs(t[0]) < best[0]:
            best = (abs(float(t[0])), k)
    return 0.0 if best is None else best[1]

