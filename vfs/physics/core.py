"""The compiled pre-crash core: one numba loop per case instead of numpy calls per step.

:class:`vfs.physics.precrash.PrecrashRun` is the reference.  It advances every
running case of a batch one 10 ms step per Python iteration, some 50-100
numpy calls per step whatever the batch size, and each case pays them over
its whole record.  :func:`replay_precrash` runs each case instance to its end
in one compiled loop over its own steps, with scalars instead of temporaries:
the record look-up of both vehicles (:mod:`vfs.physics.paths`), the speed and
arc-length reductions, the pose on the path, the broad phase (bounding
circles), the separating-axis test and the Sutherland-Hodgman clip of the
contact test, the bisection of the first contact, the penetration time, the
impact state and the closest approach.  The post-processing of the ended
cases (outline distance of far passes, grazing contacts, contact geometry)
is the reference's own (:meth:`vfs.physics.precrash_cases.PrecrashCases.finalize`),
so both paths share it.

Every operation repeats the reference's in the same order of evaluation:
the same index advances and binary searches on the same knots, the same
interpolations, the same corner order, the same clipping stages and the
shoelace sum in numpy's pairwise order (eight terms:
((c0 + c1) + (c2 + c3)) + ((c4 + c5) + (c6 + c7))).  The functions that both
evaluate with library code are cos, sin and hypot; numpy's float64 loops and
the C library round them alike on the machines we measured, so the results
are bit-identical there (``tests/physics/test_core.py`` compares every
output of both paths on generated cases of every accident type; where a
library rounds differently an ulp in a CG distance can move a tie of the
closest approach by one step, which the test would show).

What runs here: the replay of the records (no controller), the path of the
study's baseline, of the model-variant searches of :mod:`vfs.diagnosis`, of the
generator and of ``vfs compare``, as one loop per case (:func:`replay_precrash`); and
the step of every run with a controller (the AEB systems, a gym agent, a user's Python
controller) or a Python penetration rule, as one call per step over the running rows
(:func:`settle_rows`, from :class:`~vfs.physics.precrash.PrecrashRun`): the controller
runs in Python between the compiled steps, and
:func:`vfs.physics.precrash.simulate_precrash` says so once per process in the log.

Quiet steps: while the bounding circles of a case are apart
(CG distance > sum of the circumradii) no contact is possible and the
replay is the record; the loop then does only the record look-up and the CG
distance of the closest-approach bookkeeping,
no contact test.  A step cannot be left out altogether without changing the
closest approach, which the reference tracks at every step.

numba is a required dependency; the first call compiles the kernel (about
10-20 s, once: ``cache=True`` keeps the machine code in ``__pycache__``).
``VFS_COMPILED=0`` switches to the reference path.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from vfs.physics.geometry import AREA_TOLERANCE
from vfs.physics.numba_support import ENV_SWITCH, enabled, run_kernel
from vfs.physics.paths import STRAIGHT_CURVATURE
from vfs.physics.precrash_cases import PrecrashCases
from vfs.physics.precrash_contact import SEPARATION_MARGIN
from vfs.physics.precrash_result import KinematicState
from vfs.physics.vehicle import VehicleArrays

#: Knot fields (:data:`vfs.physics.paths.KNOT_FIELDS`).
_T, _S, _X, _Y, _YAW, _HEADING, _SPEED, _ACCEL = range(8)

#: Per-row outputs of the kernel, float columns of ``out_f`` (n, 2) or (n,).
_STATE_FIELDS = KinematicState._fields


# ----------------------------------------------------------------------------
# Scalar building blocks (compiled by numba below)
# ----------------------------------------------------------------------------


def _advance(knots: np.ndarray, count: np.ndarray, p: int, col: int, idx: int,
             value: float) -> int:
    """Segment index of ``value`` advanced from ``idx`` (paths.advance_index, one row)."""
    limit = count[p] - 2
    while idx < limit and knots[idx + 1, p, col] <= value:
        idx += 1
    return idx


def _search(knots: np.ndarray, count: np.ndarray, p: int, col: int, value: float) -> int:
    """Segment index of ``value`` by binary search (paths.find_index, one row)."""
    lo = 0
    hi = count[p] - 1
    if hi < 0:
        hi = 0
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if knots[mid, p, col] <= value:
            lo = mid
        else:
            hi = mid
    return lo


def _clip01(w: float) -> float:
    """numpy.clip(w, 0, 1) of a float."""
    if w < 0.0:
        return 0.0
    if w > 1.0:
        return 1.0
    return w


def _record(knots: np.ndarray, count: np.ndarray, p: int, idx: int,
            tau: float) -> tuple[float, float, float]:
    """Recorded arc length [m], speed [m/s], acceleration [m/s^2] of path ``p`` at ``tau``
    [s] in segment ``idx`` (paths.record_at_time, one row).
    """
    last = count[p] - 1
    i1 = idx + 1 if idx + 1 < last else last
    t0 = knots[idx, p, _T]
    t1 = knots[i1, p, _T]
    w = (tau - t0) / (t1 - t0) if t1 > t0 else 0.0
    w = _clip01(w)
    s0 = knots[idx, p, _S]
    v0 = knots[idx, p, _SPEED]
    s = s0 + w * (knots[i1, p, _S] - s0)
    v = v0 + w * (knots[i1, p, _SPEED] - v0)
    a = knots[idx, p, _ACCEL]
    t_end = knots[last, p, _T]
    if tau > t_end:
        v_end = knots[last, p, _SPEED]
        s = knots[last, p, _S] + v_end * (tau - t_end)
        v = v_end
        a = 0.0
    return s, v, a


def _pose(knots: np.ndarray, count: np.ndarray, end_curvature: np.ndarray, p: int, idx: int,
          s: float) -> tuple[float, float, float, float, float, float]:
    """Pose x, y [m], yaw [rad], direction (tx, ty) and curvature [1/m] of path ``p`` at
    arc length ``s`` [m] in segment ``idx`` (paths.pose_at_arclength, one row).
    """
    last = count[p] - 1
    i1 = idx + 1 if idx + 1 < last else last
    s0 = knots[idx, p, _S]
    ds = knots[i1, p, _S] - s0
    w = (s - s0) / ds if ds > 0 else 0.0
    w = _clip01(w)
    x0 = knots[idx, p, _X]
    y0 = knots[idx, p, _Y]
    dxk = knots[i1, p, _X] - x0
    dyk = knots[i1, p, _Y] - y0
    x = x0 + w * dxk
    y = y0 + w * dyk
    yaw0 = knots[idx, p, _YAW]
    yaw1 = knots[i1, p, _YAW]
    yaw = yaw0 + w * (yaw1 - yaw0)
    moving = ds > 1e-9
    inv = 1.0 / ds if moving else 0.0
    curvature = (yaw1 - yaw0) * inv
    tx = dxk * inv
    ty = dyk * inv
    if not moving:
        tx = math.cos(knots[idx, p, _HEADING])
        ty = math.sin(knots[idx, p, _HEADING])
    extra = s - knots[last, p, _S]
    if extra > 0:
        k = end_curvature[p]
        psi0 = knots[last, p, _HEADING]
        arc = k * extra
        c0 = math.cos(psi0)
        s0_ = math.sin(psi0)
        c1 = math.cos(psi0 + arc)
        s1_ = math.sin(psi0 + arc)
        if abs(k) < STRAIGHT_CURVATURE:
            dx = extra * c0
            dy = extra * s0_
        else:
            dx = (s1_ - s0_) / k
            dy = (c0 - c1) / k
        x = knots[last, p, _X] + dx
        y = knots[last, p, _Y] + dy
        yaw = knots[last, p, _YAW] + arc
        tx = c1
        ty = s1_
        curvature = k
    return x, y, yaw, tx, ty, curvature


def _put_pose(knots: np.ndarray, count: np.ndarray, end_curvature: np.ndarray, p: int,
              idx: int, s: float, speed: float, st: np.ndarray, j: int) -> None:
    """Write vehicle ``j``'s state at arc length ``s`` [m] and ``speed`` [m/s] into column
    ``j`` of ``st`` (7, 2): x, y, yaw, vx, vy, yaw rate (speed x curvature), speed.
    """
    x, y, yaw, tx, ty, curv = _pose(knots, count, end_curvature, p, idx, s)
    st[0, j] = x
    st[1, j] = y
    st[2, j] = yaw
    st[3, j] = speed * tx
    st[4, j] = speed * ty
    st[5, j] = speed * curv
    st[6, j] = speed


def _state(knots: np.ndarray, count: np.ndarray, end_curvature: np.ndarray, n_data: int,
           d: int, tau: float, dv0: float, dv1: float, ds0: float, ds1: float,
           ti: np.ndarray, si: np.ndarray, advance: bool, st: np.ndarray) -> None:
    """Kinematic state of both vehicles of data row ``d`` at ``tau`` [s] with the
    reductions dv, ds [m/s, m] (precrash_contact.kinematics_at) into ``st`` (7, 2):
    x, y, yaw, vx, vy, yaw_rate, speed.  ``advance``: the indices ``ti``, ``si`` (2,)
    are advanced from their values (a hint); else found by binary search.  The
    indices are left in ``ti``, ``si``.
    """
    for j in range(2):
        p = d + j * n_data
        dv = dv0 if j == 0 else dv1
        ds = ds0 if j == 0 else ds1
        if advance:
            ti[j] = _advance(knots, count, p, _T, ti[j], tau)
        else:
            ti[j] = _search(knots, count, p, _T, tau)
        s_rec, v_rec, _a = _record(knots, count, p, ti[j], tau)
        s = s_rec - ds
        v = v_rec - dv
        speed = v if v >= 0.0 or v != v else 0.0
        if advance:
            si[j] = _advance(knots, count, p, _S, si[j], s)
        else:
            si[j] = _search(knots, count, p, _S, s)
        _put_pose(knots, count, end_curvature, p, si[j], s, speed, st, j)


def pose_corners(x: float, y: float, yaw: float, front: float, rear: float, width: float,
             out: np.ndarray) -> None:
    """Outline corners (4, 2) [m] (geometry.outline_corners, one row)."""
    half = 0.5 * width
    c = math.cos(yaw)
    s = math.sin(yaw)
    lx = (front, front, -rear, -rear)
    ly = (-half, half, half, -half)
    for j in range(4):
        out[j, 0] = x + c * lx[j] - s * ly[j]
        out[j, 1] = y + s * lx[j] + c * ly[j]


def _frame(o: np.ndarray) -> tuple[float, float, float, float, float, float]:
    """Rectangle frame of corners (4, 2): centre, unit axis, half length, half width
    (geometry.rectangle_frame, one row).
    """
    cx = 0.5 * (o[0, 0] + o[2, 0])
    cy = 0.5 * (o[0, 1] + o[2, 1])
    alx = o[0, 0] - o[3, 0]
    aly = o[0, 1] - o[3, 1]
    acx = o[1, 0] - o[0, 0]
    acy = o[1, 1] - o[0, 1]
    length = math.hypot(alx, aly)
    return (cx, cy, alx / length, aly / length, 0.5 * length, 0.5 * math.hypot(acx, acy))


def _frames_overlap(acx: float, acy: float, ca: float, sa: float, ahl: float, ahw: float,
                    bcx: float, bcy: float, cb: float, sb: float, bhl: float,
                    bhw: float) -> bool:
    """Separating-axis test of two rectangles (geometry._frames_overlap, one row)."""
    dx = bcx - acx
    dy = bcy - acy
    ac = abs(ca * cb + sa * sb)
    as_ = abs(ca * sb - sa * cb)
    return ((abs(ca * dx + sa * dy) <= ahl + bhl * ac + bhw * as_)
            and (abs(-sa * dx + ca * dy) <= ahw + bhl * as_ + bhw * ac)
            and (abs(cb * dx + sb * dy) <= bhl + ahl * ac + ahw * as_)
            and (abs(-sb * dx + cb * dy) <= bhw + ahl * as_ + ahw * ac))


def clip_stage(px: np.ndarray, py: np.ndarray, w: int, axis: int, sign: float, bound: float,
               qx: np.ndarray, qy: np.ndarray, dist: np.ndarray) -> int:
    """One Sutherland-Hodgman stage on one polygon (geometry._clip_half_plane, one row):
    the first ``w`` slots of px, py clipped into w + 1 slots of qx, qy.  Returns the
    number of inside vertices (0: nothing left).  Plain Python, compiled by its callers
    (this module and :mod:`vfs.physics.compiled`).
    """
    n_in = 0
    for j in range(w):
        c = px[j] if axis == 0 else py[j]
        dist[j] = sign * (bound - c)
        if dist[j] >= 0.0:
            n_in += 1
    if n_in == w:
        for j in range(w):
            qx[j] = px[j]
            qy[j] = py[j]
        qx[w] = px[w - 1]
        qy[w] = py[w - 1]
        return n_in
    if n_in == 0:
        for j in range(w + 1):
            qx[j] = px[j if j < w else w - 1]
            qy[j] = py[j if j < w else w - 1]
        return 0
    start = 0
    for j in range(w):
        prev = j - 1 if j > 0 else w - 1
        if dist[j] >= 0.0 and not dist[prev] >= 0.0:
            start = j
            break
    i_in = (start + n_in - 1) % w
    i_out = (start + n_in) % w
    i_last = (start + w - 1) % w
    d_in, d_out = dist[i_in], dist[i_out]
    d_last, d_first = dist[i_last], dist[start]
    if axis == 0:
        o_in, o_out, o_last, o_first = py[i_in], py[i_out], py[i_last], py[start]
    else:
        o_in, o_out, o_last, o_first = px[i_in], px[i_out], px[i_last], px[start]
    exit_other = o_in + d_in / (d_in - d_out) * (o_out - o_in)
    entry_other = o_last + d_last / (d_last - d_first) * (o_first - o_last)
    if axis == 0:
        ex, ey, nx, ny = bound, exit_other, bound, entry_other
    else:
        ex, ey, nx, ny = exit_other, bound, entry_other, bound
    for i in range(n_in):
        k = (start + i) % w
        qx[i] = px[k]
        qy[i] = py[k]
    qx[n_in] = ex
    qy[n_in] = ey
    for i in range(n_in + 1, w + 1):
        qx[i] = nx
        qy[i] = ny
    return n_in


_clip_stage = clip_stage  # the name the compiled kernels call (rebound when compiled)


def _overlaps(o1: np.ndarray, o2: np.ndarray, buf: np.ndarray) -> bool:
    """Outlines (4, 2) overlap with an area > AREA_TOLERANCE (precrash_contact.overlapping:
    the separating-axis test with SEPARATION_MARGIN first, then the clip and the shoelace
    area in numpy's order).  ``buf`` (5, 8) is scratch.
    """
    acx, acy, ca, sa, ahl, ahw = _frame(o1)
    bcx, bcy, cb, sb, bhl, bhw = _frame(o2)
    m = SEPARATION_MARGIN
    if not _frames_overlap(acx, acy, ca, sa, ahl + m, ahw + m, bcx, bcy, cb, sb, bhl + m,
                           bhw + m):
        return False
    return clipped_overlap(o1, o2, buf)


def clipped_overlap(o1: np.ndarray, o2: np.ndarray, buf: np.ndarray) -> bool:
    """Outlines (4, 2) [m] overlap with an area > AREA_TOLERANCE [m^2]
    (``geometry.overlap(o1, o2).area > AREA_TOLERANCE``, one row: the clip in the frame of
    ``o2`` and the shoelace area in numpy's order).  ``buf`` (5, 8) is scratch.
    """
    bcx, bcy, cb, sb, bhl, bhw = _frame(o2)
    ax, ay, bx, by, dist = buf[0], buf[1], buf[2], buf[3], buf[4]
    for j in range(4):
        dx = o1[j, 0] - bcx
        dy = o1[j, 1] - bcy
        ax[j] = cb * dx + sb * dy
        ay[j] = -sb * dx + cb * dy
    alive = True
    if _clip_stage(ax, ay, 4, 0, 1.0, bhl, bx, by, dist) == 0:
        alive = False
    if _clip_stage(bx, by, 5, 1, 1.0, bhw, ax, ay, dist) == 0:
        alive = False
    if _clip_stage(ax, ay, 6, 0, -1.0, -bhl, bx, by, dist) == 0:
        alive = False
    if _clip_stage(bx, by, 7, 1, -1.0, -bhw, ax, ay, dist) == 0:
        alive = False
    if not alive:
        return False
    ox = ax[0]
    oy = ay[0]
    for j in range(8):
        jn = j + 1 if j < 7 else 0
        rx = ax[j] - ox
        ry = ay[j] - oy
        dist[j] = rx * (ay[jn] - oy) - (ax[jn] - ox) * ry
    # numpy's pairwise sum of eight terms
    twice = ((dist[0] + dist[1]) + (dist[2] + dist[3])) + ((dist[4] + dist[5])
                                                           + (dist[6] + dist[7]))
    if not abs(twice) > 2.0 * AREA_TOLERANCE:
        return False
    return 0.5 * twice > AREA_TOLERANCE


def _corner_gap(o: np.ndarray, cx: float, cy: float, c: float, s: float, hl: float,
                hw: float) -> float:
    """Smallest distance [m] of the corners ``o`` (4, 2) to a rectangle
    (geometry._corners_to_frame, one row).
    """
    best = math.inf
    for j in range(4):
        dx = o[j, 0] - cx
        dy = o[j, 1] - cy
        x = c * dx + s * dy
        y = -s * dx + c * dy
        gx = abs(x) - hl
        gx = gx if gx >= 0.0 else 0.0
        gy = abs(y) - hw
        gy = gy if gy >= 0.0 else 0.0
        g = math.sqrt(gx * gx + gy * gy)
        if g < best:
            best = g
    return best


def _distance(o1: np.ndarray, o2: np.ndarray) -> float:
    """Outline distance [m] (geometry.outline_distance, one row)."""
    acx, acy, ca, sa, ahl, ahw = _frame(o1)
    bcx, bcy, cb, sb, bhl, bhw = _frame(o2)
    if _frames_overlap(acx, acy, ca, sa, ahl, ahw, bcx, bcy, cb, sb, bhl, bhw):
        return 0.0
    g1 = _corner_gap(o1, bcx, bcy, cb, sb, bhl, bhw)
    g2 = _corner_gap(o2, acx, acy, ca, sa, ahl, ahw)
    return g1 if g1 <= g2 else g2


def _outlines_of(st: np.ndarray, dims: np.ndarray, d: int, o1: np.ndarray,
                 o2: np.ndarray) -> None:
    """Both outlines of data row ``d`` in state ``st`` (7, 2); ``dims`` (n_data, 6):
    front, rear, width of vehicle 1, then of vehicle 2 [m].
    """
    pose_corners(st[0, 0], st[1, 0], st[2, 0], dims[d, 0], dims[d, 1], dims[d, 2], o1)
    pose_corners(st[0, 1], st[1, 1], st[2, 1], dims[d, 3], dims[d, 4], dims[d, 5], o2)


def _step_state(knots: np.ndarray, count: np.ndarray, end_curvature: np.ndarray, n_data: int,
                d: int, kk: int, dt: float, dv: np.ndarray, ds: np.ndarray, gap: np.ndarray,
                ti: np.ndarray, si: np.ndarray, st: np.ndarray, rec: np.ndarray) -> None:
    """One step of a row on its own clock (step ``kk``, time kk dt [s]): advance the record
    indices ``ti`` and the arc-length reduction ``ds`` (trapezoidal rule of
    min(dv, v_rec)), the state of both vehicles into ``st`` (7, 2), the recorded speed
    and acceleration into ``rec`` (2, 2) (PrecrashRun._settle, one row).
    """
    tau = kk * dt
    for j in range(2):
        p = d + j * n_data
        ti[j] = _advance(knots, count, p, _T, ti[j], tau)
        s_rec, v_rec, a_rec = _record(knots, count, p, ti[j], tau)
        rec[0, j] = v_rec
        rec[1, j] = a_rec
        gap_now = dv[j] if dv[j] <= v_rec or dv[j] != dv[j] else v_rec
        if kk > 0:
            ds[j] = ds[j] + 0.5 * dt * (gap[j] + gap_now)
        gap[j] = gap_now
        s = s_rec - ds[j]
        v = v_rec - dv[j]
        speed = v if v >= 0.0 or v != v else 0.0
        si[j] = _advance(knots, count, p, _S, si[j], s)
        _put_pose(knots, count, end_curvature, p, si[j], s, speed, st, j)


def _bisect(knots: np.ndarray, count: np.ndarray, end_curvature: np.ndarray, dims: np.ndarray,
            n_data: int, d: int, t_free: float, t_hit: float, dv0: np.ndarray,
            dv1: np.ndarray, ds0: np.ndarray, ds1: np.ndarray, ti0: np.ndarray,
            si0: np.ndarray, tolerance: float, hti: np.ndarray, hsi: np.ndarray,
            tmp: np.ndarray, o1: np.ndarray, o2: np.ndarray, buf: np.ndarray) -> float:
    """First-contact time [s] between a free and an overlapping step by bisection
    (precrash_contact.bisect_contact, one row): dv, ds interpolated linearly, the record
    indices advanced from those of the free step (``ti0``, ``si0``).
    """
    lo = t_free
    hi = t_hit
    span = hi - lo
    while span > tolerance:
        mid = 0.5 * (lo + hi)
        w = (mid - t_free) / (t_hit - t_free)
        hti[0], hti[1] = ti0[0], ti0[1]
        hsi[0], hsi[1] = si0[0], si0[1]
        _state(knots, count, end_curvature, n_data, d, mid,
               dv0[0] + w * (dv1[0] - dv0[0]), dv0[1] + w * (dv1[1] - dv0[1]),
               ds0[0] + w * (ds1[0] - ds0[0]), ds0[1] + w * (ds1[1] - ds0[1]),
               hti, hsi, True, tmp)
        _outlines_of(tmp, dims, d, o1, o2)
        if _overlaps(o1, o2, buf):
            hi = mid
        else:
            lo = mid
        span *= 0.5
    return hi


# ----------------------------------------------------------------------------
# The case loop
# ----------------------------------------------------------------------------

#: Columns of the kernel's float outputs per row (``out`` (n, _NOUT)).
(_COLLIDED, _CONTACT_T, _IMPACT_T, _MIN_D, _T_CLOSE, _BEST_T, _END_K, _CLOSED) = range(8)
_NOUT = 8


def _replay_rows(knots: np.ndarray, count: np.ndarray, end_curvature: np.ndarray,
                 dims: np.ndarray, reach: np.ndarray, case_horizon: np.ndarray,
                 data_row: np.ndarray, first: np.ndarray, dt: float, horizon: float,
                 penetration_time: float, tolerance: float, close_range: float,
                 out: np.ndarray, states: np.ndarray, reductions: np.ndarray) -> None:
    """Replay every row to its end (compiled; rows in parallel threads).

    ``states`` (n, 4, 7, 2): impact, contact, end and best (closest CG distance) state;
    ``reductions`` (n, 3, 2): speed reduction at the end, dv and ds at first contact.
    """
    n_data = dims.shape[0]
    n = data_row.shape[0]
    for i in numba_prange(n):
        d = data_row[i]
        j0 = first[i]
        st = np.empty((7, 2))
        tmp = np.empty((7, 2))
        o1 = np.empty((4, 2))
        o2 = np.empty((4, 2))
        buf = np.empty((5, 8))
        rec = np.empty((2, 2))
        ti = np.zeros(2, dtype=np.int64)
        si = np.zeros(2, dtype=np.int64)
        hti = np.zeros(2, dtype=np.int64)
        hsi = np.zeros(2, dtype=np.int64)
        dv = np.zeros(2)
        ds = np.zeros(2)
        gap = np.zeros(2)
        prev_dv = np.zeros(2)
        prev_ds = np.zeros(2)
        prev_ti = np.zeros(2, dtype=np.int64)
        prev_si = np.zeros(2, dtype=np.int64)
        best_centre = math.inf
        best_time = math.nan
        min_distance = math.inf
        time_closest = math.nan
        collided = False
        pending = False
        contact_time = math.nan
        impact_time = math.nan
        closed = False
        for a in range(4):
            for f in range(7):
                states[i, a, f, 0] = math.nan
                states[i, a, f, 1] = math.nan
        for a in range(3):
            reductions[i, a, 0] = 0.0
            reductions[i, a, 1] = 0.0
        k = 0
        while True:
            kk = k + j0
            tau = kk * dt
            prev_tau = (kk - 1) * dt
            # ---- kinematics at this step (record_pair, state_at_arclength)
            _step_state(knots, count, end_curvature, n_data, d, kk, dt, dv, ds, gap, ti, si,
                        st, rec)
            ended = False
            # ---- impact time reached
            if pending and impact_time <= tau + 1e-12:
                w = _clip01((impact_time - prev_tau) / dt)
                dv0 = prev_dv[0] + w * (dv[0] - prev_dv[0])
                dv1 = prev_dv[1] + w * (dv[1] - prev_dv[1])
                ds0 = prev_ds[0] + w * (ds[0] - prev_ds[0])
                ds1 = prev_ds[1] + w * (ds[1] - prev_ds[1])
                _state(knots, count, end_curvature, n_data, d, impact_time, dv0, dv1, ds0,
                       ds1, hti, hsi, False, tmp)
                states[i, 0] = tmp
                pending = False
                reductions[i, 0, 0] = dv0
                reductions[i, 0, 1] = dv1
                ended = True
            if not ended:
                # ---- contact detection (broad phase: bounding circles)
                free = not pending
                centre = math.hypot(st[0, 0] - st[0, 1], st[1, 0] - st[1, 1])
                lower = centre - reach[d]
                touching = False
                if free and lower <= 0.0:
                    _outlines_of(st, dims, d, o1, o2)
                    touching = _overlaps(o1, o2, buf)
                if touching:
                    t_c = 0.0
                    if kk != 0:
                        t_c = _bisect(knots, count, end_curvature, dims, n_data, d, prev_tau,
                                      tau, prev_dv, dv, prev_ds, ds, prev_ti, prev_si,
                                      tolerance, hti, hsi, tmp, o1, o2, buf)
                    collided = True
                    contact_time = t_c
                    pending = True
                    min_distance = 0.0
                    time_closest = t_c
                    w = 0.0 if kk == 0 else _clip01((t_c - prev_tau) / dt)
                    dv0 = prev_dv[0] + w * (dv[0] - prev_dv[0])
                    dv1 = prev_dv[1] + w * (dv[1] - prev_dv[1])
                    ds0 = prev_ds[0] + w * (ds[0] - prev_ds[0])
                    ds1 = prev_ds[1] + w * (ds[1] - prev_ds[1])
                    _state(knots, count, end_curvature, n_data, d, t_c, dv0, dv1, ds0, ds1,
                           hti, hsi, False, tmp)
                    states[i, 1] = tmp
                    reductions[i, 1, 0] = dv0
                    reductions[i, 1, 1] = dv1
                    reductions[i, 2, 0] = ds0
                    reductions[i, 2, 1] = ds1
                    impact_time = t_c + penetration_time
                    if penetration_time == 0.0:
                        states[i, 0] = tmp
                        pending = False
                        reductions[i, 0, 0] = dv0
                        reductions[i, 0, 1] = dv1
                # ---- closest approach (exact outline distance within close_range)
                if free and centre < best_centre:
                    best_centre = centre
                    best_time = tau
                    for j in range(2):
                        states[i, 3, 0, j] = st[0, j]
                        states[i, 3, 1, j] = st[1, j]
                        states[i, 3, 2, j] = st[2, j]
                    bound = min_distance if min_distance <= close_range else close_range
                    if not touching and lower < bound:
                        _outlines_of(st, dims, d, o1, o2)
                        dist = _distance(o1, o2)
                        if dist < min_distance:
                            min_distance = dist
                            time_closest = tau
                if not pending and collided:
                    ended = True
                elif not pending and tau >= case_horizon[i] - 1e-9:
                    ended = True
                    closed = True
                    states[i, 2] = st
                    reductions[i, 0, 0] = dv[0]
                    reductions[i, 0, 1] = dv[1]
                elif k * dt >= horizon:
                    # the run's end (PrecrashRun: time >= horizon closes every row)
                    ended = True
                    closed = True
                    states[i, 2] = st
                    reductions[i, 0, 0] = dv[0]
                    reductions[i, 0, 1] = dv[1]
            if ended:
                break
            # ---- advance (no demand: the delivered deceleration stays 0)
            for j in range(2):
                prev_dv[j] = dv[j]
                prev_ds[j] = ds[j]
                prev_ti[j] = ti[j]
                prev_si[j] = si[j]
            k += 1
        out[i, _COLLIDED] = 1.0 if collided else 0.0
        out[i, _CONTACT_T] = contact_time
        out[i, _IMPACT_T] = impact_time
        out[i, _MIN_D] = min_distance
        out[i, _T_CLOSE] = time_closest
        out[i, _BEST_T] = best_time
        out[i, _END_K] = k
        out[i, _CLOSED] = 1.0 if closed else 0.0


#: Event codes of :func:`settle_rows` per running row.
EVENT_NONE, EVENT_IMPACT, EVENT_CONTACT = 0, 1, 2


def _settle_rows(knots: np.ndarray, count: np.ndarray, end_curvature: np.ndarray,
                 dims: np.ndarray, reach: np.ndarray, data: np.ndarray, kk: np.ndarray,
                 dt: float, tolerance: float, close_range: float, dv: np.ndarray,
                 ds: np.ndarray, gap: np.ndarray, t_index: np.ndarray, s_index: np.ndarray,
                 prev_dv: np.ndarray, prev_ds: np.ndarray, prev_ti: np.ndarray,
                 prev_si: np.ndarray, best_centre: np.ndarray, best_time: np.ndarray,
                 best_x: np.ndarray, best_y: np.ndarray, best_yaw: np.ndarray,
                 pending: np.ndarray, impact_time: np.ndarray, min_distance: np.ndarray,
                 time_closest: np.ndarray, st_out: np.ndarray, rec_out: np.ndarray,
                 event: np.ndarray, ev_state: np.ndarray, ev_f: np.ndarray) -> None:
    """One step of the running rows of a :class:`~vfs.physics.precrash.PrecrashRun`
    (compiled): kinematics, impacts due, contact test and bisection, closest approach.

    Arrays over the m running rows: ``reach``, ``data`` (data row), ``kk`` (step on the
    row's clock), the track (``dv`` .. ``best_yaw``, updated in place), ``pending`` and
    ``impact_time`` (read), ``min_distance`` and ``time_closest`` (updated).  Out:
    ``st_out`` (7, m, 2) the state, ``rec_out`` (2, m, 2) recorded speed and
    acceleration, ``event`` (m,) :data:`EVENT_IMPACT` (impact time reached: ``ev_state``
    the impact state, ``ev_f[:, 1:3]`` dv there) or :data:`EVENT_CONTACT` (first
    contact: ``ev_f[:, 0]`` its time, ``ev_f[:, 1:3]`` dv, ``ev_f[:, 3:5]`` ds,
    ``ev_state`` the contact state).  The caller applies the penetration time.
    """
    n_data = dims.shape[0]
    m = data.shape[0]
    st = np.empty((7, 2))
    tmp = np.empty((7, 2))
    rec = np.empty((2, 2))
    o1 = np.empty((4, 2))
    o2 = np.empty((4, 2))
    buf = np.empty((5, 8))
    hti = np.zeros(2, dtype=np.int64)
    hsi = np.zeros(2, dtype=np.int64)
    for i in range(m):
        d = data[i]
        k = kk[i]
        tau = k * dt
        prev_tau = (k - 1) * dt
        _step_state(knots, count, end_curvature, n_data, d, k, dt, dv[i], ds[i], gap[i],
                    t_index[i], s_index[i], st, rec)
        for f in range(7):
            st_out[f, i, 0] = st[f, 0]
            st_out[f, i, 1] = st[f, 1]
        for f in range(2):
            rec_out[f, i, 0] = rec[f, 0]
            rec_out[f, i, 1] = rec[f, 1]
        event[i] = EVENT_NONE
        if pending[i]:
            if impact_time[i] <= tau + 1e-12:
                w = _clip01((impact_time[i] - prev_tau) / dt)
                dv0 = prev_dv[i, 0] + w * (dv[i, 0] - prev_dv[i, 0])
                dv1 = prev_dv[i, 1] + w * (dv[i, 1] - prev_dv[i, 1])
                ds0 = prev_ds[i, 0] + w * (ds[i, 0] - prev_ds[i, 0])
                ds1 = prev_ds[i, 1] + w * (ds[i, 1] - prev_ds[i, 1])
                _state(knots, count, end_curvature, n_data, d, impact_time[i], dv0, dv1, ds0,
                       ds1, hti, hsi, False, tmp)
                ev_state[i] = tmp
                ev_f[i, 1] = dv0
                ev_f[i, 2] = dv1
                event[i] = EVENT_IMPACT
            continue
        centre = math.hypot(st[0, 0] - st[0, 1], st[1, 0] - st[1, 1])
        lower = centre - reach[i]
        touching = False
        if lower <= 0.0:
            _outlines_of(st, dims, d, o1, o2)
            touching = _overlaps(o1, o2, buf)
        if touching:
            t_c = 0.0
            if k != 0:
                t_c = _bisect(knots, count, end_curvature, dims, n_data, d, prev_tau, tau,
                              prev_dv[i], dv[i], prev_ds[i], ds[i], prev_ti[i], prev_si[i],
                              tolerance, hti, hsi, tmp, o1, o2, buf)
            w = 0.0 if k == 0 else _clip01((t_c - prev_tau) / dt)
            dv0 = prev_dv[i, 0] + w * (dv[i, 0] - prev_dv[i, 0])
            dv1 = prev_dv[i, 1] + w * (dv[i, 1] - prev_dv[i, 1])
            ds0 = prev_ds[i, 0] + w * (ds[i, 0] - prev_ds[i, 0])
            ds1 = prev_ds[i, 1] + w * (ds[i, 1] - prev_ds[i, 1])
            _state(knots, count, end_curvature, n_data, d, t_c, dv0, dv1, ds0, ds1, hti,
                   hsi, False, tmp)
            ev_state[i] = tmp
            ev_f[i, 0] = t_c
            ev_f[i, 1] = dv0
            ev_f[i, 2] = dv1
            ev_f[i, 3] = ds0
            ev_f[i, 4] = ds1
            event[i] = EVENT_CONTACT
        if centre < best_centre[i]:
            best_centre[i] = centre
            best_time[i] = tau
            for j in range(2):
                best_x[i, j] = st[0, j]
                best_y[i, j] = st[1, j]
                best_yaw[i, j] = st[2, j]
            md = 0.0 if touching else min_distance[i]
            bound = md if md <= close_range else close_range
            if not touching and lower < bound:
                _outlines_of(st, dims, d, o1, o2)
                dist = _distance(o1, o2)
                if dist < md:
                    min_distance[i] = dist
                    time_closest[i] = tau


numba_prange = range  # numba.prange inside the compiled kernel

#: Building blocks compiled inline into the kernels (each row's step).
_INLINED = frozenset({"_advance", "_clip01", "_record", "_pose", "_put_pose", "_step_state"})

_kernel: Any = None
_settle_kernel: Any = None


def _compiled() -> Any:
    """The compiled replay kernel (compiled, or loaded from numba's cache, at the first
    call; the step kernel with it).
    """
    global _kernel, _settle_kernel
    if _kernel is None:
        import numba

        opts = {"cache": True, "nogil": True, "error_model": "numpy"}
        g = globals()
        for name in ("_advance", "_search", "_clip01", "_record", "_pose", "_put_pose", "_state",
                     "pose_corners", "_frame", "_frames_overlap", "_clip_stage",
                     "clipped_overlap", "_overlaps", "_corner_gap", "_distance",
                     "_outlines_of", "_step_state", "_bisect"):
            # the building blocks of every row's step inlined (numba IR, the same
            # arithmetic): the step kernel runs some 40 % faster without the calls and the
            # array views they take (issue 37, benchmarks/results/core_37_gym2_profile.txt)
            inline = "always" if name in _INLINED else "never"
            g[name] = numba.njit(inline=inline, **opts)(g[name])
        g["numba_prange"] = numba.prange
        _kernel = numba.njit(parallel=False, **opts)(_replay_rows)
        _settle_kernel = numba.njit(**opts)(_settle_rows)
    return _kernel


def geometry_kernels() -> tuple[Any, Any]:
    """The compiled :func:`pose_corners` and :func:`clipped_overlap` (numba dispatchers, for
    the kernels of other modules: :mod:`vfs.physics.core_runout`).
    """
    _compiled()
    g = globals()
    return g["pose_corners"], g["clipped_overlap"]


def settle_rows(*args: Any) -> None:
    """The compiled step of the running rows of a pre-crash run (arguments as
    :func:`_settle_rows` documents them; :meth:`vfs.physics.precrash.PrecrashRun` calls it).
    """
    _compiled()
    run_kernel(_settle_kernel, "step of the pre-crash core", *args)


def replay_precrash(vehicle1: VehicleArrays, vehicle2: VehicleArrays, paths: Any,
                    params: Any, close_range: float, case_of: np.ndarray | None = None,
                    first_step: np.ndarray | None = None) -> Any:
    """The pre-crash replay of the records (no controller), compiled; the same
    :class:`~vfs.physics.precrash_result.PrecrashResult` as
    :func:`vfs.physics.precrash.simulate_precrash` without a controller and without a
    penetration rule.

    Parameters
    ----------
    vehicle1, vehicle2 : VehicleArrays
    paths : PathArrays
        Participant 1's records, then participant 2's.
    params : PrecrashParams
    close_range : float
        Outline distances are tracked exactly while the bounding circles are closer
        than this [m] (:data:`vfs.physics.precrash.CLOSE_RANGE`).
    case_of, first_step : ndarray of int, optional
        Case instances and the step of its record each starts at
        (:func:`~vfs.physics.precrash.simulate_precrash`).

    Returns
    -------
    PrecrashResult
    """
    n_data = vehicle1.size
    data_row = (np.arange(n_data, dtype=np.int64) if case_of is None
                else np.ascontiguousarray(case_of, dtype=np.int64).reshape(-1))
    n = data_row.shape[0]
    first = (np.zeros(n, dtype=np.int64) if first_step is None
             else np.ascontiguousarray(np.broadcast_to(np.asarray(first_step, np.int64), (n,))))
    cases = PrecrashCases(vehicle1, vehicle2, paths, params.dt, n,
                          None if case_of is None else data_row)
    duration = paths.duration
    case_horizon = (np.maximum(duration[:n_data], duration[n_data:])
                    + params.extra_time)[data_row]
    horizon = float(np.max(case_horizon)) if n else 0.0
    reach = vehicle1.corner_radius + vehicle2.corner_radius
    dims = np.ascontiguousarray(np.stack([vehicle1.cg_to_front, vehicle1.cg_to_rear,
                                          vehicle1.width, vehicle2.cg_to_front,
                                          vehicle2.cg_to_rear, vehicle2.width], axis=1),
                                dtype=float)
    out = np.empty((n, _NOUT))
    states = np.empty((n, 4, 7, 2))
    reductions = np.empty((n, 3, 2))
    if n:
        run_kernel(_compiled(), "replay of the pre-crash core",
                   np.ascontiguousarray(paths.knots, dtype=float),
                   np.ascontiguousarray(paths.count, dtype=np.int64),
                   np.ascontiguousarray(paths.end_curvature, dtype=float), dims,
                   np.ascontiguousarray(reach, dtype=float),
                   np.ascontiguousarray(case_horizon, dtype=float), data_row, first,
                   float(params.dt), horizon, float(params.penetration_time),
                   float(params.contact_tolerance), float(close_range), out, states,
                   reductions)
    cases.collided[:] = out[:, _COLLIDED] > 0.5
    cases.contact_time[:] = out[:, _CONTACT_T]
    cases.impact_time[:] = out[:, _IMPACT_T]
    cases.min_distance[:] = out[:, _MIN_D]
    cases.time_closest[:] = out[:, _T_CLOSE]
    # the reference keeps the closest CG pose only for rows closed without an impact
    closed = out[:, _CLOSED] > 0.5
    cases.best_time[:] = np.where(closed, out[:, _BEST_T], np.nan)
    for slot, target in enumerate((cases.impact_state, cases.contact_state, cases.end_state)):
        for f, arr in enumerate(target):
            arr[:] = states[:, slot, f]
    for f in range(3):
        cases.best_pose[f] = np.where(closed[:, None], states[:, 3, f], np.nan)
    cases.speed_reduction[:] = reductions[:, 0]
    cases.contact_dv[:] = reductions[:, 1]
    cases.contact_ds[:] = reductions[:, 2]
    cases.k = int(out[:, _END_K].max()) if n else 0
    cases.running = np.zeros(n, dtype=bool)
    cases.rows = np.zeros(0, dtype=np.int64)
    return cases.result()


__all__ = ["ENV_SWITCH", "EVENT_CONTACT", "EVENT_IMPACT", "EVENT_NONE", "clipped_overlap",
           "enabled", "geometry_kernels", "pose_corners", "replay_precrash", "settle_rows"]
