"""Recorded pre-crash paths packed as arrays, with vectorised look-ups.

A participant's pre-crash record (PreCrash-Matrix style: t, x, y, yaw, speed,
optional acceleration) is turned into an arc-length parameterised path: the
CG moves along the polyline of recorded positions, s is the cumulative chord
length, the vehicle's yaw is interpolated in s (it follows the path as
recorded, side slip included) and the direction of motion is the direction
of the polyline segment.  Beyond the end of the record the path continues
as a constant-curvature arc (the curvature of the last second of the
record) at constant speed, documented in docs/physics.md.

N paths of different lengths are packed into padded arrays of shape (N, M);
look-ups take an index per row and work on all rows at once.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import numpy.typing as npt

#: Curvatures below this [1/m] are extrapolated as straight lines.
STRAIGHT_CURVATURE = 1e-6

#: Time span [s] at the end of a record over which the extrapolation
#: curvature is averaged.
EXTRAPOLATION_WINDOW = 1.0


#: Fields of a path knot, in their order in :attr:`PathArrays.knots`.
KNOT_FIELDS = ("t", "s", "x", "y", "yaw", "heading", "speed", "accel")
_T, _S, _X, _Y, _YAW, _HEADING, _SPEED, _ACCEL = range(len(KNOT_FIELDS))


class PathArrays(NamedTuple):
    """N recorded paths as padded arrays; padding repeats the last sample.

    The knots are stored sample-major and interleaved, ``knots[j, i]`` =
    (t, s, x, y, yaw, heading, speed, accel) of sample j of path i: all paths
    advance through their records together, so the look-ups of one time step
    read one contiguous slab (one cache line per path) instead of scattered
    values of eight large arrays.

    Attributes
    ----------
    knots : ndarray (M, N, 8)
        Per sample: time [s, relative to the record's first sample], arc
        length [m] (cumulative chord length), CG x, y [m], vehicle yaw [rad,
        unwrapped], direction of motion of the segment starting at the sample
        [rad] (the yaw where the segment has zero length), recorded speed
        [m/s], recorded longitudinal acceleration [m/s^2] (the record's, or
        the speed's finite differences where it has none).
    count : ndarray of int (N,)
        Number of valid samples per path.
    t0 : ndarray (N,)
        Absolute time of the first sample [s] (to map back to record time).
    end_curvature : ndarray (N,)
        Curvature of the extrapolation beyond the record [1/m].
    """

    knots: np.ndarray
    count: np.ndarray  # type: ignore[assignment]  # a field named like tuple.count
    t0: np.ndarray
    end_curvature: np.ndarray

    @property
    def t(self) -> np.ndarray:
        """Sample times [s] (N, M)."""
        return self.knots[..., _T].T

    @property
    def s(self) -> np.ndarray:
        """Arc length [m] (N, M)."""
        return self.knots[..., _S].T

    @property
    def x(self) -> np.ndarray:
        """CG x [m] (N, M)."""
        return self.knots[..., _X].T

    @property
    def y(self) -> np.ndarray:
        """CG y [m] (N, M)."""
        return self.knots[..., _Y].T

    @property
    def yaw(self) -> np.ndarray:
        """Yaw [rad] (N, M)."""
        return self.knots[..., _YAW].T

    @property
    def heading(self) -> np.ndarray:
        """Direction of motion [rad] (N, M)."""
        return self.knots[..., _HEADING].T

    @property
    def speed(self) -> np.ndarray:
        """Speed [m/s] (N, M)."""
        return self.knots[..., _SPEED].T

    @property
    def accel(self) -> np.ndarray:
        """Acceleration [m/s^2] (N, M)."""
        return self.knots[..., _ACCEL].T

    @property
    def size(self) -> int:
        """Number of paths N."""
        return int(self.count.shape[0])

    def last(self, name: str) -> np.ndarray:
        """Value of field ``name`` at each path's last valid sample (N,)."""
        return self.knots[self.count - 1, np.arange(self.size), KNOT_FIELDS.index(name)]

    @property
    def duration(self) -> np.ndarray:
        """Duration of each record [s] (N,)."""
        return self.last("t")

    def take(self, index: npt.ArrayLike) -> PathArrays:
        """Select paths by index or mask."""
        rows = np.arange(self.size)[index]
        # one contiguous copy (knots[:, rows] would lay the copy out along the rows first)
        return PathArrays(np.take(self.knots, rows, axis=1), self.count[rows],
                          self.t0[rows], self.end_curvature[rows])

    def last_knots(self) -> np.ndarray:
        """Each path's last valid knot, shape (N, 8) (compute once per simulation)."""
        return self.knots[self.count - 1, np.arange(self.size)]

    def knot_rows(self, rows: np.ndarray, columns: np.ndarray) -> np.ndarray:
        """Knots of paths ``rows`` at sample ``columns``, shape (n, 8)."""
        flat = columns * self.knots.shape[1] + rows
        return self.knots.reshape(-1, len(KNOT_FIELDS))[flat]


def pack_paths(
    t: npt.ArrayLike, x: npt.ArrayLike, y: npt.ArrayLike, yaw: npt.ArrayLike,
    speed: npt.ArrayLike, group: npt.ArrayLike, accel: npt.ArrayLike | None = None,
) -> PathArrays:
    """Pack long-format samples into :class:`PathArrays`.

    Parameters
    ----------
    t, x, y, yaw, speed : array_like (L,)
        Samples [s, m, m, rad, m/s], sorted by group and then by time.
    group : array_like (L,)
        Path index 0..N-1 of each sample (non-decreasing).
    accel : array_like (L,), optional
        Recorded acceleration [m/s^2]; NaN or missing entries are replaced
        by the central finite difference of the speed.
    """
    t = np.asarray(t, float)
    group = np.asarray(group, dtype=np.int64)
    n = int(group.max()) + 1 if group.size else 0
    count = np.bincount(group, minlength=n)
    start = np.concatenate([[0], np.cumsum(count)[:-1]])
    m = int(count.max()) if n else 0

    # sample of each padded cell: path i's sample j, its last one repeated into the padding
    cells = start[:n, None] + np.minimum(np.arange(m)[None, :], (count - 1)[:, None])

    def pad(values: np.ndarray) -> np.ndarray:
        return values[cells]

    pt, px, py = pad(t), pad(np.asarray(x, float)), pad(np.asarray(y, float))
    pyaw = np.unwrap(pad(np.asarray(yaw, float)), axis=1)
    pv = pad(np.asarray(speed, float))
    t0 = pt[:, 0].copy()
    pt -= t0[:, None]
    # (the temporaries are few and reused: a first call's fresh memory costs page faults)
    dx, dy = np.diff(px, axis=1), np.diff(py, axis=1)
    seg = np.hypot(dx, dy)
    ps = np.concatenate([np.zeros((n, 1)), np.cumsum(seg, axis=1)], axis=1)
    # direction of motion per segment; zero-length segments keep the yaw
    dir_seg = np.arctan2(dy, dx)
    del dx, dy
    moving = seg > 1e-9
    heading = np.concatenate([dir_seg, dir_seg[:, -1:]], axis=1) if m > 1 else pyaw.copy()
    heading = np.where(np.concatenate([moving, moving[:, -1:]], axis=1) if m > 1 else False,
                       heading, pyaw)
    # unwrap relative to the yaw so that heading and yaw stay close
    turn = np.multiply(1j, heading - pyaw)
    heading = np.angle(np.exp(turn, out=turn))
    del turn
    heading += pyaw
    # acceleration: record where given, else central differences of speed
    dv = np.gradient(pv, axis=1) if m > 1 else np.zeros_like(pv)
    dt = np.gradient(pt, axis=1) if m > 1 else np.ones_like(pt)
    with np.errstate(invalid="ignore", divide="ignore"):
        fd = np.where(dt > 0, dv / dt, 0.0)
    if accel is None:
        pa = fd
    else:
        pa = pad(np.asarray(accel, float))
        pa = np.where(np.isnan(pa), fd, pa)
    end_curvature = _end_curvature(pt, ps, pyaw, count)
    # written field by field into the C-ordered (m, n, 8) array (no stacked copy)
    knots = np.empty((m, n, len(KNOT_FIELDS)))
    for k, values in enumerate((pt, ps, px, py, pyaw, heading, pv, pa)):
        knots[:, :, k] = values.T
    return PathArrays(knots, count, t0, end_curvature)


def concat_paths(first: PathArrays, second: PathArrays) -> PathArrays:
    """Paths of ``first`` followed by those of ``second`` (padded to a common length)."""
    m = max(first.knots.shape[0], second.knots.shape[0])

    def padded(p: PathArrays) -> np.ndarray:
        if p.knots.shape[0] == m:
            return p.knots
        extra = np.repeat(p.knots[-1:], m - p.knots.shape[0], axis=0)
        return np.concatenate([p.knots, extra], axis=0)

    return PathArrays(np.ascontiguousarray(np.concatenate([padded(first), padded(second)],
                                                          axis=1)),
                      np.concatenate([first.count, second.count]),
                      np.concatenate([first.t0, second.t0]),
                      np.concatenate([first.end_curvature, second.end_curvature]))


def _end_curvature(t: np.ndarray, s: np.ndarray, yaw: np.ndarray,
                   count: np.ndarray) -> np.ndarray:
    """Mean curvature d(yaw)/ds over the last EXTRAPOLATION_WINDOW seconds [1/m]."""
    rows = np.arange(t.shape[0])
    last = count - 1
    t_end = t[rows, last]
    first = np.argmax(t >= (t_end - EXTRAPOLATION_WINDOW)[:, None], axis=1)
    ds = s[rows, last] - s[rows, first]
    dyaw = yaw[rows, last] - yaw[rows, first]
    with np.errstate(invalid="ignore", divide="ignore"):
        k = np.where(ds > 0.5, dyaw / ds, 0.0)
    return k


# ----------------------------------------------------------------------------
# Look-ups
# ----------------------------------------------------------------------------


def advance_index(paths: PathArrays, field: str, index: np.ndarray, value: np.ndarray,
                  rows: np.ndarray) -> np.ndarray:
    """Advance per-row segment indices so that knot[i] <= value < knot[i + 1].

    ``field`` is 't' or 's'.  For monotonically non-decreasing queries (time,
    arc length) each call moves an index by a few knots at most, so the loop
    is short.  ``rows`` are the path numbers of ``index``.
    """
    col = KNOT_FIELDS.index(field)
    flat = paths.knots.reshape(-1, len(KNOT_FIELDS))
    n_paths = paths.knots.shape[1]
    idx = index.copy()
    limit = paths.count[rows] - 2
    while True:
        nxt = np.minimum(idx + 1, np.maximum(limit + 1, 0))
        move = (idx < limit) & (flat[nxt * n_paths + rows, col] <= value)
        if not move.any():
            return idx
        idx += move


def find_index(paths: PathArrays, field: str, value: np.ndarray,
               rows: np.ndarray) -> np.ndarray:
    """Segment index per row for arbitrary (not monotone) queries (binary search)."""
    col = KNOT_FIELDS.index(field)
    flat = paths.knots.reshape(-1, len(KNOT_FIELDS))
    n_paths = paths.knots.shape[1]
    lo = np.zeros(rows.shape, dtype=np.int64)
    hi = np.maximum(paths.count[rows] - 1, 0)
    while True:
        active = hi - lo > 1
        if not active.any():
            return lo
        mid = (lo + hi) // 2
        go_right = flat[mid * n_paths + rows, col] <= value
        lo = np.where(active & go_right, mid, lo)
        hi = np.where(active & ~go_right, mid, hi)


class RecordState(NamedTuple):
    """Recorded kinematics at query times (arrays (n,))."""

    s: np.ndarray  # arc length [m]
    speed: np.ndarray  # [m/s]
    accel: np.ndarray  # [m/s^2]


def record_at_time(paths: PathArrays, rows: np.ndarray, index: np.ndarray,
                   tau: np.ndarray, last: np.ndarray | None = None,
                   rows_last: bool = False) -> RecordState:
    """Recorded arc length, speed and acceleration at times ``tau`` [s] (relative).

    ``index`` must be the segment index of ``tau`` (see :func:`advance_index`);
    ``last`` may pass :meth:`PathArrays.last_knots` computed once (or, with
    ``rows_last``, already taken at ``rows``).
    Inside the record: linear interpolation in time.  Beyond its end: constant
    speed, zero acceleration.
    """
    count = paths.count[rows]
    k0 = paths.knot_rows(rows, index)
    k1 = paths.knot_rows(rows, np.minimum(index + 1, count - 1))
    kl = (paths.last_knots() if last is None else last)
    kl = kl if rows_last else kl[rows]
    t0, t1 = k0[:, _T], k1[:, _T]
    with np.errstate(invalid="ignore", divide="ignore"):
        w = np.where(t1 > t0, (tau - t0) / (t1 - t0), 0.0)
    w = np.clip(w, 0.0, 1.0)
    s = k0[:, _S] + w * (k1[:, _S] - k0[:, _S])
    v = k0[:, _SPEED] + w * (k1[:, _SPEED] - k0[:, _SPEED])
    a = k0[:, _ACCEL]
    t_end = kl[:, _T]
    beyond = tau > t_end
    if beyond.any():
        v_end = kl[:, _SPEED]
        s = np.where(beyond, kl[:, _S] + v_end * (tau - t_end), s)
        v = np.where(beyond, v_end, v)
        a = np.where(beyond, 0.0, a)
    return RecordState(s, v, a)


class PathPose(NamedTuple):
    """Pose on the path at query arc lengths (arrays (n,))."""

    x: np.ndarray  # CG position [m]
    y: np.ndarray  # [m]
    yaw: np.ndarray  # vehicle heading [rad]
    tx: np.ndarray  # unit vector of the direction of motion [-]
    ty: np.ndarray
    curvature: np.ndarray  # d(yaw)/ds [1/m]


def pose_at_arclength(paths: PathArrays, rows: np.ndarray, index: np.ndarray,
                      s: np.ndarray, last: np.ndarray | None = None,
                      rows_last: bool = False) -> PathPose:
    """Pose at arc lengths ``s`` [m]; ``index`` is the segment index of ``s``.

    Inside the record: linear interpolation of x, y and yaw in s (so a replay
    at the recorded s(t) reproduces the recorded positions).  Beyond its end:
    a constant-curvature arc continuing the last heading.
    """
    count = paths.count[rows]
    k0 = paths.knot_rows(rows, index)
    k1 = paths.knot_rows(rows, np.minimum(index + 1, count - 1))
    s0, s1 = k0[:, _S], k1[:, _S]
    ds = s1 - s0
    with np.errstate(invalid="ignore", divide="ignore"):
        w = np.where(ds > 0, (s - s0) / ds, 0.0)
    w = np.clip(w, 0.0, 1.0)
    x = k0[:, _X] + w * (k1[:, _X] - k0[:, _X])
    y = k0[:, _Y] + w * (k1[:, _Y] - k0[:, _Y])
    yaw0, yaw1 = k0[:, _YAW], k1[:, _YAW]
    yaw = yaw0 + w * (yaw1 - yaw0)
    # direction of motion: the segment's chord, or its recorded heading
    # where the segment has zero length (standstill)
    moving = ds > 1e-9
    with np.errstate(invalid="ignore", divide="ignore"):
        inv = np.where(moving, 1.0 / ds, 0.0)
        curvature = (yaw1 - yaw0) * inv
    tx = (k1[:, _X] - k0[:, _X]) * inv
    ty = (k1[:, _Y] - k0[:, _Y]) * inv
    # (the trigonometric functions are evaluated on the rows that need them only:
    # float64 sin/cos cost about 50 times a multiplication)
    if not moving.all():
        still = np.flatnonzero(~moving)
        tx[still] = np.cos(k0[still, _HEADING])
        ty[still] = np.sin(k0[still, _HEADING])
    # beyond the record: arc of constant curvature from the last sample
    kl = (paths.last_knots() if last is None else last)
    kl = kl if rows_last else kl[rows]
    extra = s - kl[:, _S]
    beyond = extra > 0
    if beyond.any():
        b = np.flatnonzero(beyond)
        kb, eb = kl[b], extra[b]
        k = paths.end_curvature[rows[b]]
        psi0 = kb[:, _HEADING]
        arc = k * eb
        straight = np.abs(k) < STRAIGHT_CURVATURE
        c0, s0_ = np.cos(psi0), np.sin(psi0)
        c1, s1_ = np.cos(psi0 + arc), np.sin(psi0 + arc)
        with np.errstate(invalid="ignore", divide="ignore"):
            dx = np.where(straight, eb * c0, (s1_ - s0_) / k)
            dy = np.where(straight, eb * s0_, (c0 - c1) / k)
        x[b] = kb[:, _X] + dx
        y[b] = kb[:, _Y] + dy
        yaw[b] = kb[:, _YAW] + arc
        tx[b], ty[b] = c1, s1_
        curvature[b] = k
    return PathPose(x, y, yaw, tx, ty, curvature)
