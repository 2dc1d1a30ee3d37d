"""The generic AEB controller's measurement as compiled (numba) loops over the egos.

:class:`vfs.adas.controller.AEBController` runs these kernels by default; its numpy
path (``VFS_COMPILED=0``, :func:`vfs.physics.numba_support.enabled`) is the tests' reference.
Per sensor cycle the numpy path makes some hundreds of passes over small arrays (the
threat assessment of :mod:`vfs.adas.threat`: the reach bound, the constant-velocity and
the sampled sweeps of the predicted outlines with the swept separating axes, the
last-moment rule's braked sweeps; the field-of-view sector of :mod:`vfs.adas.sensor`;
the stage logic), each writing temporaries; the kernels do each ego's work in one pass
with scalars.

Three kernels per measurement (:func:`measure`):

1. :func:`_reach` -- the horizon each ego still needs (``AEBController._needed_horizon``),
   the reach bound (:func:`vfs.adas.threat.earliest_contact`) and the sensor geometry
   of the egos within reach (the object in the sensor frame, the closest point);
2. numpy's ``arctan2`` of the closest points' bearings, then :func:`_sector` -- the
   bearing test and the three boundary rays of the sector
   (:func:`vfs.adas.sensor.sector_distance`);
3. the detection draws (numpy, from the controller's generators, as in the reference),
   then :func:`_assess` -- the TTC of the detected objects
   (:func:`vfs.adas.threat.time_to_collision`) and the stage logic with the last-moment
   rule (``AEBController._decide``, ``_last_moment``), written into the controller's
   stage and TTC arrays.

Bit identity with the reference: every operation repeats numpy's, in the same order
of evaluation (``x * x`` where numpy squares; numpy's ``maximum``/``minimum``, which
return the second argument on ties and propagate NaN, by :func:`_fmax`/:func:`_fmin`;
no fast-math, so no fused multiply-add).  The sampled sweeps depend on the set of
pairs a call of the reference gets (the grid of each group of pairs runs to the
largest interval count of the group, and a group whose paths are all straight keeps
the outlines' yaw without adding the zero turn): the kernels form the same sets and
groups.  The functions cos, sin, hypot and sqrt round alike in numba and numpy on the machines we
measured; ``arctan2`` does not (numpy's SIMD routine differs from the C library's in
the last bit for a few per cent of arguments), so it stays in numpy between the
kernels.  ``tests/adas/test_compiled_aeb.py`` compares both paths output by output.

The random draws (detection, the driver) stay in numpy; the latency queue, the
actuation of the decisions and the demand stay in :class:`AEBController`: a few array
operations per step, not per ego.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from vfs.adas.params import STANDSTILL_SPEED, Prediction, Release
from vfs.adas.threat import MIN_STEP
from vfs.physics.braking import G
from vfs.physics.geometry import STILL_DISPLACEMENT
from vfs.physics.numba_support import require_numba, run_kernel

#: Codes of the prediction models and release rules inside the kernels.
MODEL_CODES = {Prediction.CV.value: 0, Prediction.CTRV.value: 1, Prediction.CA.value: 2,
               Prediction.CTRA.value: 3}
RELEASE_CODES = {Release.TTC.value: 0, Release.STANDSTILL.value: 1, Release.NEVER.value: 2}

#: Rows of a packed :class:`~vfs.adas.threat.Motion`, its fields in order (:func:`gather_pairs`).
_X, _Y, _YAW, _HEADING, _SPEED, _ACCEL, _YAW_RATE, _HL, _HW, _OFF = range(10)

#: Ray direction components below this count as parallel (vfs.adas.sensor).
_PARALLEL = 1e-12

#: Upper bounds of the interval counts by which the sampled sweep groups its pairs
#: (vfs.adas.threat).
_GROUP_BOUNDS = (4.5, 16.5, 64.5)

#: Margin [m] of the sweep's skip of intervals out of reach (rounding of the positions is
#: some 1e-12 m): an interval is left out only where it is this much farther than needed.
_SKIP_MARGIN = 1e-6

#: Sampling step [s] and time after standstill [s] of the last-moment rule's sweep
#: (the defaults of vfs.adas.threat.braked_contact).
BRAKED_STEP = 0.1
BRAKED_TAIL = 0.3


# ----------------------------------------------------------------------------
# Scalar building blocks
# ----------------------------------------------------------------------------


def _fmax(a: float, b: float) -> float:
    """numpy.maximum of two floats: NaN propagates; on ties the second."""
    if a != a:
        return a
    if b != b:
        return b
    return a if a > b else b


def _fmin(a: float, b: float) -> float:
    """numpy.minimum of two floats: NaN propagates; on ties the second."""
    if a != a:
        return a
    if b != b:
        return b
    return a if a < b else b


def _wrap(a: float) -> float:
    """:func:`vfs.units.wrap_angle` of one angle [rad]: np.mod(a + pi, 2 pi) - pi, -pi -> pi."""
    # Python's float remainder is numpy's: fmod, then the sign of the divisor
    w = (a + np.pi) % (2.0 * np.pi) - np.pi
    if w == -np.pi:
        return np.pi
    return w


def _slab(origin: float, rate: float, half: float, still: float) -> tuple[float, float]:
    """Interval of the parameter t in which origin + rate t lies in [-half, half] (a
    separating-axis slab or a ray's box slab): all t or none where |rate| < ``still``,
    else between (-half - origin) / rate and (half - origin) / rate, in numpy's min/max.
    """
    if abs(rate) < still:
        inside = abs(origin) <= half
        return (-np.inf if inside else np.inf), (np.inf if inside else -np.inf)
    t1 = (-half - origin) / rate
    t2 = (half - origin) / rate
    return _fmin(t1, t2), _fmax(t1, t2)


def _circumradius(m: np.ndarray, i: int) -> float:
    """Motion.circumradius of row ``i``: corner_radius(h + c, h - c, 2 w) [m]."""
    h = m[_HL, i]
    c = m[_OFF, i]
    return math.hypot(_fmax(h + c, h - c), 0.5 * (2.0 * m[_HW, i]))


def _model_accel(m: np.ndarray, i: int, model: int) -> float:
    """Acceleration [m/s^2] the prediction ``model`` keeps (threat.model_terms)."""
    if model == 2 or model == 3:
        return m[_ACCEL, i]
    return 0.0


def _model_curvature(m: np.ndarray, i: int, model: int) -> float:
    """Path curvature [1/m] the prediction ``model`` keeps (threat.model_terms)."""
    if model == 1 or model == 3:
        v = m[_SPEED, i]
        if v > 0.0:
            return m[_YAW_RATE, i] / v
        return 0.0
    return 0.0


def _first_contact(dx: float, dy: float, ddx: float, ddy: float, yaw_a: float, hl_a: float,
                   hw_a: float, yaw_b: float, hl_b: float, hw_b: float) -> float:
    """:func:`vfs.physics.geometry.first_contact` of one pair (docs/aeb.md eq. 3.1)."""
    return _first_contact_cs(dx, dy, ddx, ddy, math.cos(yaw_a), math.sin(yaw_a), hl_a, hw_a,
                             math.cos(yaw_b), math.sin(yaw_b), hl_b, hw_b)


def _first_contact_cs(dx: float, dy: float, ddx: float, ddy: float, ca: float, sa: float,
                      hl_a: float, hw_a: float, cb: float, sb: float, hl_b: float,
                      hw_b: float) -> float:
    """:func:`_first_contact` with the cosines and sines of both yaws given (a sweep's
    straight predictions keep their yaws: computed once per pair, not per interval).
    """
    cos_d = abs(ca * cb + sa * sb)
    sin_d = abs(sa * cb - ca * sb)
    enter = 0.0
    leave = 0.0
    for k in range(4):
        if k == 0:
            p = ca * dx + sa * dy
            w = ca * ddx + sa * ddy
            rho = hl_a + hl_b * cos_d + hw_b * sin_d
        elif k == 1:
            p = ca * dy - sa * dx
            w = ca * ddy - sa * ddx
            rho = hw_a + hl_b * sin_d + hw_b * cos_d
        elif k == 2:
            p = cb * dx + sb * dy
            w = cb * ddx + sb * ddy
            rho = hl_b + hl_a * cos_d + hw_a * sin_d
        else:
            p = cb * dy - sb * dx
            w = cb * ddy - sb * ddx
            rho = hw_b + hl_a * sin_d + hw_a * cos_d
        lo, hi = _slab(p, w, rho, STILL_DISPLACEMENT)
        if k == 0:
            enter = lo
            leave = hi
        else:
            enter = _fmax(enter, lo)
            leave = _fmin(leave, hi)
    if (enter <= leave) and (enter <= 1.0) and (leave >= 0.0):
        return _fmax(enter, 0.0)
    return np.inf


def _earliest(a: np.ndarray, b: np.ndarray, i: int, model: int, ego_accel: bool) -> float:
    """:func:`vfs.adas.threat.earliest_contact` of pair ``i`` [s]; ``ego_accel`` False:
    A's acceleration taken as 0 (the braking ego of ``braked_contact``).
    """
    gap = (math.hypot(b[_X, i] - a[_X, i], b[_Y, i] - a[_Y, i]) - _circumradius(a, i)
           - _circumradius(b, i))
    closing = a[_SPEED, i] + b[_SPEED, i]
    acc_a = _model_accel(a, i, model) if ego_accel else 0.0
    gain = _fmax(acc_a, 0.0) + _fmax(_model_accel(b, i, model), 0.0)
    if gap <= 0.0:
        return 0.0
    if (closing > 0.0) or (gain > 0.0):
        return 2.0 * gap / (closing + math.sqrt(closing * closing + 2.0 * gain * gap))
    return np.inf


def _ttc_cv(a: np.ndarray, b: np.ndarray, i: int, horizon: float) -> float:
    """:func:`vfs.adas.threat.ttc_cv` of pair ``i`` [s]."""
    ca, sa = math.cos(a[_YAW, i]), math.sin(a[_YAW, i])
    cb, sb = math.cos(b[_YAW, i]), math.sin(b[_YAW, i])
    dx = b[_X, i] + b[_OFF, i] * cb - a[_X, i] - a[_OFF, i] * ca
    dy = b[_Y, i] + b[_OFF, i] * sb - a[_Y, i] - a[_OFF, i] * sa
    rvx = b[_SPEED, i] * math.cos(b[_HEADING, i]) - a[_SPEED, i] * math.cos(a[_HEADING, i])
    rvy = b[_SPEED, i] * math.sin(b[_HEADING, i]) - a[_SPEED, i] * math.sin(a[_HEADING, i])
    s = _first_contact_cs(dx, dy, rvx * horizon, rvy * horizon, ca, sa, a[_HL, i], a[_HW, i],
                          cb, sb, b[_HL, i], b[_HW, i])
    return s * horizon


def _predicted_arclength(v: float, acc: float, t: float) -> float:
    """:func:`vfs.adas.threat.predicted_arclength` [m] at one time ``t`` [s]."""
    stop = v / (-acc) if acc < 0.0 else np.inf
    tau = _fmin(t, stop)
    return v * tau + 0.5 * acc * tau * tau


def _braked_arclength(v: float, delay: float, decel: float, t: float) -> float:
    """:func:`vfs.adas.threat.braked_arclength` [m] at one time ``t`` [s]."""
    braking = _fmin(_fmax(t - delay, 0.0), v / decel)
    return v * _fmin(t, delay) + v * braking - 0.5 * decel * (braking * braking)


def _path_cg(m: np.ndarray, i: int, u: float, k: float, curved: bool, ch: float,
             sh: float) -> tuple[float, float]:
    """:func:`vfs.adas.threat.path_cg` of row ``i`` after arc length ``u`` [m]; ``curved``:
    some path of the reference's group curves (else its straight formula); ``ch``, ``sh``:
    cos and sin of the row's heading (computed once per pair by the caller).
    """
    if not curved:
        return m[_X, i] + u * ch, m[_Y, i] + u * sh
    half_turn = 0.5 * k * u
    sin_h, cos_h = math.sin(half_turn), math.cos(half_turn)
    if abs(half_turn) < 1e-6:
        ratio = 1.0 - half_turn * half_turn / 6.0
    else:
        ratio = sin_h / half_turn
    chord = u * ratio
    return (m[_X, i] + chord * (ch * cos_h - sh * sin_h),
            m[_Y, i] + chord * (sh * cos_h + ch * sin_h))


def _sweep_point(a: np.ndarray, b: np.ndarray, i: int, t: float, acc_a: float, k_a: float,
                 acc_b: float, k_b: float, curved_a: bool, curved_b: bool, braked: bool,
                 delay: float, decel: float, heading: tuple[float, float, float, float]
                 ) -> tuple[float, float, float, float, float, float]:
    """Arc lengths [m] of both predictions of pair ``i`` at time ``t`` [s] (A braked at
    ``decel`` after ``delay`` where ``braked``) and their CG positions [m]:
    (ua, ub, xa, ya, xb, yb); ``heading``: cos and sin of A's heading, then of B's.
    """
    if braked:
        ua = _braked_arclength(a[_SPEED, i], delay, decel, t)
    else:
        ua = _predicted_arclength(a[_SPEED, i], acc_a, t)
    ub = _predicted_arclength(b[_SPEED, i], acc_b, t)
    xa, ya = _path_cg(a, i, ua, k_a, curved_a, heading[0], heading[1])
    xb, yb = _path_cg(b, i, ub, k_b, curved_b, heading[2], heading[3])
    return ua, ub, xa, ya, xb, yb


def _sweep(a: np.ndarray, b: np.ndarray, i: int, model: int, start: float, end: float,
           step: float, intervals: int, curved_a: bool, curved_b: bool, braked: bool,
           delay: float, decel: float, bound: float) -> float:
    """First contact time [s] of pair ``i`` swept on the grid start + j step (j = 0 ..
    ``intervals``, capped at ``end``): :func:`vfs.adas.threat.sampled_contact` over the
    samples of ``ttc_sampled`` (``braked`` False) or of ``braked_contact`` (A brakes at
    ``decel`` after ``delay``); inf without contact.
    """
    acc_a = _model_accel(a, i, model)
    k_a = _model_curvature(a, i, model)
    acc_b = _model_accel(b, i, model)
    k_b = _model_curvature(b, i, model)
    reach_r = _circumradius(a, i) + _circumradius(b, i)
    # loop invariants, each computed once per pair (the same numbers as per interval):
    # the headings' cosines and sines, and the yaws' where a prediction does not turn
    heading = (math.cos(a[_HEADING, i]), math.sin(a[_HEADING, i]),
               math.cos(b[_HEADING, i]), math.sin(b[_HEADING, i]))
    ca, sa = math.cos(a[_YAW, i]), math.sin(a[_YAW, i])
    cb, sb = math.cos(b[_YAW, i]), math.sin(b[_YAW, i])
    best = np.inf
    t0 = _fmin(start + 0.0 * step, end)
    ua0, ub0, xa0, ya0, xb0, yb0 = _sweep_point(a, b, i, t0, acc_a, k_a, acc_b, k_b, curved_a,
                                                curved_b, braked, delay, decel, heading)
    travel = bound * step  # the most the separation can shrink over one interval [m]
    j = 0
    while j < intervals:
        if not t0 < end:
            break  # this and the later intervals are not counted
        if t0 > best:
            break  # every later contact is later than the one found
        t1 = _fmin(start + float(j + 1) * step, end)
        ua1, ub1, xa1, ya1, xb1, yb1 = _sweep_point(a, b, i, t1, acc_a, k_a, acc_b, k_b,
                                                    curved_a, curved_b, braked, delay, decel,
                                                    heading)
        sep_x = xb0 - xa0
        sep_y = yb0 - ya0
        reach = reach_r + bound * (t1 - t0)
        if sep_x * sep_x + sep_y * sep_y <= reach * reach:
            if curved_a:
                yaw_a = a[_YAW, i] + k_a * 0.5 * (ua0 + ua1)
                ca, sa = math.cos(yaw_a), math.sin(yaw_a)
            if curved_b:
                yaw_b = b[_YAW, i] + k_b * 0.5 * (ub0 + ub1)
                cb, sb = math.cos(yaw_b), math.sin(yaw_b)
            dx = sep_x + b[_OFF, i] * cb - a[_OFF, i] * ca
            dy = sep_y + b[_OFF, i] * sb - a[_OFF, i] * sa
            ddx = (xb1 - xb0) - (xa1 - xa0)
            ddy = (yb1 - yb0) - (ya1 - ya0)
            s = _first_contact_cs(dx, dy, ddx, ddy, ca, sa, a[_HL, i], a[_HW, i], cb, sb,
                                  b[_HL, i], b[_HW, i])
            if math.isfinite(s):
                best = _fmin(best, t0 + s * (t1 - t0))
        j += 1
        t0, ua0, ub0, xa0, ya0, xb0, yb0 = t1, ua1, ub1, xa1, ya1, xb1, yb1
        # Intervals the reach test above cannot pass are left out: the separation at a
        # later sample shrinks by at most ``bound`` [m/s] times the time between (bound:
        # both speeds' upper bound over the sweep), and an interval is looked at only
        # while it is within reach_r + travel.  Landing on sample j + skip gives the
        # numbers stepping there would (every sample is computed from its own time).
        if travel > 0.0:
            gap = math.hypot(xb0 - xa0, yb0 - ya0) - reach_r - travel - _SKIP_MARGIN
            skip = int(gap / travel) if gap > travel else 0
            if skip > 0 and j < intervals:
                j = min(j + skip, intervals)
                t0 = _fmin(start + float(j) * step, end)
                ua0, ub0, xa0, ya0, xb0, yb0 = _sweep_point(
                    a, b, i, t0, acc_a, k_a, acc_b, k_b, curved_a, curved_b, braked, delay,
                    decel, heading)
    return best


def _grid_intervals(span: float) -> int:
    """Interval count of a group's grid (threat._grid): max(ceil(span - 1e-9), 1)."""
    k = math.ceil(span - 1e-9)
    return k if k > 1 else 1


def _error_terms(m: np.ndarray, i: int, model: int,
                 horizon: float) -> tuple[float, float, float, float]:
    """|acceleration|, top speed, |turn rate| (threat._error_terms) and circumradius."""
    acc = _model_accel(m, i, model)
    k = _model_curvature(m, i, model)
    top = m[_SPEED, i] + _fmax(acc, 0.0) * horizon
    return abs(acc), top, abs(k) * top, _circumradius(m, i)


def _ttc_batch(a: np.ndarray, b: np.ndarray, idx: np.ndarray, horizon: np.ndarray,
               model: int, tolerance: float, max_step: float, out: np.ndarray) -> None:
    """:func:`vfs.adas.threat.time_to_collision` of the pairs ``idx`` (one call of the
    reference with these pairs, horizons ``horizon[idx]`` [s]) into ``out[idx]`` [s].
    """
    n = idx.shape[0]
    if model == 0:
        for q in range(n):
            i = idx[q]
            out[i] = _ttc_cv(a, b, i, horizon[i])
        return
    # deviation from CV (eq. 3.5): exact CV sweep below the tolerance
    sampled = np.zeros(n, dtype=np.bool_)
    for q in range(n):
        i = idx[q]
        h = horizon[i]
        total = 0.0
        for v in range(2):
            acc, top, turn, r = _error_terms(a if v == 0 else b, i, model, h)
            total = total + turn * h * (0.5 * top * h + r) + 0.5 * acc * h * h
        if total > tolerance:
            sampled[q] = True
        else:
            out[i] = _ttc_cv(a, b, i, h)
    # ttc_sampled over the sampled pairs: reach bound, step, groups by interval count
    first = np.empty(n)
    step = np.empty(n)
    group = np.full(n, -1, dtype=np.int64)
    span = np.full(4, -np.inf)
    curved = np.zeros((4, 2), dtype=np.bool_)
    for q in range(n):
        if not sampled[q]:
            continue
        i = idx[q]
        end = horizon[i]
        out[i] = np.inf
        first[q] = _earliest(a, b, i, model, True)
        if not first[q] <= end:
            continue
        quad = 0.0
        lin = 0.0
        for v in range(2):
            acc, top, turn, r = _error_terms(a if v == 0 else b, i, model, end)
            quad = quad + (turn * top + acc) / 8.0
            lin = lin + turn * r / 2.0
        st = 2.0 * tolerance / (lin + math.sqrt(lin * lin + 4.0 * quad * tolerance))
        st = _fmin(_fmax(st, MIN_STEP), max_step)
        step[q] = st
        count = math.ceil((end - first[q]) / st)
        g = 3
        for c in range(3):
            if count < _GROUP_BOUNDS[c]:
                g = c
                break
        group[q] = g
        span[g] = _fmax(span[g], (end - first[q]) / st)
        if _model_curvature(a, i, model) != 0.0:
            curved[g, 0] = True
        if _model_curvature(b, i, model) != 0.0:
            curved[g, 1] = True
    for q in range(n):
        g = group[q]
        if g < 0:
            continue
        i = idx[q]
        end = horizon[i]
        # ttc_sampled: bound = bound + speed + max(accel, 0) * end, A then B
        bound = 0.0 + a[_SPEED, i] + _fmax(_model_accel(a, i, model), 0.0) * end
        bound = bound + b[_SPEED, i] + _fmax(_model_accel(b, i, model), 0.0) * end
        out[i] = _sweep(a, b, i, model, first[q], end, step[q], _grid_intervals(span[g]),
                        curved[g, 0], curved[g, 1], False, 0.0, 1.0, bound)


def _braked_batch(a: np.ndarray, b: np.ndarray, idx: np.ndarray, delay: np.ndarray,
                  decel: np.ndarray, horizon: float, model: int, out: np.ndarray) -> None:
    """:func:`vfs.adas.threat.braked_contact` of the pairs ``idx`` (one call of the
    reference with these pairs; delays [s] and decelerations [m/s^2] per pair ``i``)
    into ``out[idx]``.
    """
    n = idx.shape[0]
    first = np.empty(n)
    end = np.empty(n)
    live = np.zeros(n, dtype=np.bool_)
    span = -np.inf
    curved_a = False
    curved_b = False
    for q in range(n):
        i = idx[q]
        out[i] = False
        end[q] = _fmax(delay[i] + a[_SPEED, i] / decel[i] + BRAKED_TAIL, horizon)
        first[q] = _earliest(a, b, i, model, False)
        if first[q] <= end[q]:
            live[q] = True
            span = _fmax(span, (end[q] - first[q]) / BRAKED_STEP)
            if _model_curvature(a, i, model) != 0.0:
                curved_a = True
            if _model_curvature(b, i, model) != 0.0:
                curved_b = True
    if span == -np.inf:
        return  # nothing within reach
    intervals = _grid_intervals(span)
    for q in range(n):
        if not live[q]:
            continue
        i = idx[q]
        bound = a[_SPEED, i] + b[_SPEED, i] + _fmax(_model_accel(b, i, model), 0.0) * end[q]
        hit = _sweep(a, b, i, model, first[q], end[q], BRAKED_STEP, intervals, curved_a,
                     curved_b, True, delay[i], decel[i], bound)
        out[i] = math.isfinite(hit)


# ----------------------------------------------------------------------------
# The kernels of a measurement
# ----------------------------------------------------------------------------


def _reach(ego: np.ndarray, obj: np.ndarray, active: np.ndarray, front: np.ndarray,
           thresholds: np.ndarray, release_thresholds: np.ndarray, model: int,
           release: int, last_moment: bool, min_speed: float, max_speed: float,
           ttc_horizon: float, mount_x: float, mount_y: float, mount_yaw: float,
           ml: float, mw: float, horizon: np.ndarray, near: np.ndarray,
           geo: np.ndarray) -> None:
    """Horizon [s], reach (``near``) and sensor geometry of each ego (kernel 1).

    ``geo`` (8, n) receives, for the egos within reach, the object's centre in the
    frame of its outline (lx, ly [m]), the half extents less the margins [m], the
    closest point relative to the sensor (qx, qy [m]), its distance [m] and the
    boresight [rad] (:func:`vfs.adas.sensor.sector_distance`).
    """
    n = ego.shape[1]
    for i in range(n):
        speed = ego[_SPEED, i]
        window = (speed >= min_speed) and (speed <= max_speed)
        need = 0.0
        for k in range(3):
            thr = thresholds[k]
            on = not math.isnan(thr)
            value = thr if (not active[i, k]) and on and window else 0.0
            need = value if k == 0 else _fmax(need, value)
        if release == 0:
            rel = 0.0
            for k in range(3):
                on = not math.isnan(thresholds[k])
                value = release_thresholds[k] if active[i, k] and on else 0.0
                rel = value if k == 0 else _fmax(rel, value)
            need = _fmax(need, rel)
        if last_moment and window and not active[i, 2]:
            need = ttc_horizon
        need = _fmin(need, ttc_horizon)
        horizon[i] = need
        near[i] = (need > 0.0) and (_earliest(ego, obj, i, model, True) <= need)
        if not near[i]:
            continue
        ce, se = math.cos(ego[_YAW, i]), math.sin(ego[_YAW, i])
        mx = front[i] + mount_x
        co, so = math.cos(obj[_YAW, i]), math.sin(obj[_YAW, i])
        sx = ego[_X, i] + ce * mx - se * mount_y
        sy = ego[_Y, i] + se * mx + ce * mount_y
        cx = obj[_X, i] + obj[_OFF, i] * co
        cy = obj[_Y, i] + obj[_OFF, i] * so
        hl = obj[_HL, i] - ml
        hw = obj[_HW, i] - mw
        c, s = math.cos(obj[_YAW, i]), math.sin(obj[_YAW, i])
        dx, dy = sx - cx, sy - cy
        lx = c * dx + s * dy
        ly = -s * dx + c * dy
        qx = _fmin(_fmax(lx, -hl), hl) - lx
        qy = _fmin(_fmax(ly, -hw), hw) - ly
        geo[0, i], geo[1, i], geo[2, i], geo[3, i] = lx, ly, hl, hw
        geo[4, i], geo[5, i] = qx, qy
        geo[6, i] = math.hypot(qx, qy)
        geo[7, i] = ego[_YAW, i] + mount_yaw


def _ray_entry(lx: float, ly: float, ex: float, ey: float, hl: float, hw: float) -> float:
    """Entry distance [m] of a ray into the box [-hl, hl] x [-hw, hw] (sensor._ray_entry)."""
    lo_x = hi_x = lo_y = hi_y = 0.0
    for axis in range(2):
        origin, direction, half = (lx, ex, hl) if axis == 0 else (ly, ey, hw)
        lo, hi = _slab(origin, direction, half, _PARALLEL)
        if axis == 0:
            lo_x, hi_x = lo, hi
        else:
            lo_y, hi_y = lo, hi
    enter = _fmax(_fmax(lo_x, lo_y), 0.0)
    leave = _fmin(hi_x, hi_y)
    return enter if leave >= enter else np.inf


def _sector(obj: np.ndarray, near: np.ndarray, geo: np.ndarray, bearing: np.ndarray,
            half_angle: float, max_range: float, seen: np.ndarray) -> None:
    """Whether each ego within reach sees its object's outline (kernel 2); ``bearing``:
    numpy's arctan2(qy, qx) of the egos within reach, in order.
    """
    q = 0
    for i in range(near.shape[0]):
        if not near[i]:
            seen[i] = False
            continue
        closest = geo[6, i]
        if half_angle >= np.pi:
            seen[i] = closest <= max_range
            continue
        yaw = obj[_YAW, i]
        boresight = geo[7, i]
        direction = _wrap(bearing[q] + yaw - boresight)
        q += 1
        best = closest if (closest == 0.0) or (abs(direction) <= half_angle) else np.inf
        for r in range(3):
            offset = -half_angle if r == 0 else (0.0 if r == 1 else half_angle)
            phi = boresight + offset - yaw
            best = _fmin(best, _ray_entry(geo[0, i], geo[1, i], math.cos(phi), math.sin(phi),
                                          geo[2, i], geo[3, i]))
        seen[i] = best <= max_range


def _assess(ego: np.ndarray, obj: np.ndarray, case: np.ndarray, col: np.ndarray,
            horizon: np.ndarray, found: np.ndarray, update: np.ndarray,
            friction: np.ndarray, stage: np.ndarray, ttc_state: np.ndarray,
            thresholds: np.ndarray, release_thresholds: np.ndarray, model: int,
            tolerance: float, max_step: float, release: int, last_moment: bool,
            min_speed: float, max_speed: float, ttc_horizon: float,
            full_deceleration: float, max_deceleration: float, jerk: float,
            lag_delay: float, latency: float, cycle_time: float, dt: float) -> None:
    """TTC of the detected objects and the stage logic of the egos ``update`` (kernel 3).

    Writes the controller's ``stage`` (N, 2, 3) and ``ttc_state`` (N, 2) at (case,
    col).  ``jerk`` > 0: the jerk-limited actuator; else ``lag_delay`` [s] is the
    first-order actuator's equivalent delay (``actuator_delay``).
    """
    n = ego.shape[1]
    ttc = np.full(n, np.inf)
    sel = np.flatnonzero(found)
    if sel.size:
        _ttc_batch(ego, obj, sel, horizon, model, tolerance, max_step, ttc)
    upd = np.flatnonzero(update)
    m = upd.size
    # the last-moment rule (AEBController._last_moment) over the checked egos
    due = np.zeros(n, dtype=np.bool_)
    if last_moment:
        check = np.zeros(m, dtype=np.int64)
        nc = 0
        available = np.zeros(n)
        now = np.zeros(n)
        late_delay = np.zeros(n)
        for q in range(m):
            i = upd[q]
            if math.isfinite(ttc[i]) and not stage[case[i], col[i], 2] and ego[_SPEED, i] > 0.0:
                check[nc] = i
                nc += 1
                av = _fmin(_fmin(friction[i] * G, full_deceleration), max_deceleration)
                available[i] = av
                delay = 0.5 * _fmax(av / jerk, dt) if jerk > 0.0 else lag_delay
                now[i] = latency + delay
                late_delay[i] = now[i] + _fmax(cycle_time, dt)
        if nc:
            checked = check[:nc]
            late = np.zeros(n, dtype=np.bool_)
            _braked_batch(ego, obj, checked, late_delay, available, ttc_horizon, model, late)
            late_idx = checked[late[checked]]
            if late_idx.size:
                unavoidable = np.zeros(n, dtype=np.bool_)
                _braked_batch(ego, obj, late_idx, now, available, ttc_horizon, model,
                              unavoidable)
                for i in late_idx:
                    ahead = ((obj[_X, i] + obj[_OFF, i] * math.cos(obj[_YAW, i]) - ego[_X, i]
                              - ego[_OFF, i] * math.cos(ego[_YAW, i]))
                             * math.cos(ego[_HEADING, i])
                             + (obj[_Y, i] + obj[_OFF, i] * math.sin(obj[_YAW, i])
                                - ego[_Y, i] - ego[_OFF, i] * math.sin(ego[_YAW, i]))
                             * math.sin(ego[_HEADING, i])) > 0.0
                    due[i] = (not unavoidable[i]) or ahead
    # trigger, hold or release (AEBController._decide)
    for q in range(m):
        i = upd[q]
        c, j = case[i], col[i]
        speed = ego[_SPEED, i]
        value = ttc[i]
        window = (speed >= min_speed) and (speed <= max_speed)
        for k in range(3):
            trigger = (value <= thresholds[k]) and window
            if k == 2 and last_moment:
                trigger = trigger or (window and due[i])
            if release == 0:
                rel = (value > release_thresholds[k]) or math.isinf(value)
            elif release == 1:
                rel = speed <= STANDSTILL_SPEED
            else:
                rel = False
            stage[c, j, k] = (not rel) if stage[c, j, k] else trigger
        ttc_state[c, j] = value


def _gather_pairs(x: np.ndarray, y: np.ndarray, yaw: np.ndarray, heading: np.ndarray,
                  speed: np.ndarray, accel: np.ndarray, yaw_rate: np.ndarray,
                  outline: np.ndarray, rows: np.ndarray, ri: np.ndarray, ji: np.ndarray,
                  a: np.ndarray, b: np.ndarray) -> None:
    """The egos (running row ``ri``, participant ``ji``) and their objects packed into
    ``a`` and ``b`` (10, m) (``AEBController._packed_pairs``): the observation's fields
    (flat (2 n,): index 2 row + participant), the heading replaced by the yaw at
    standstill, and the outline rows (3, 2 N) of the case's participants.
    """
    for q in range(ri.shape[0]):
        for side in range(2):
            out = a if side == 0 else b
            j = ji[q] if side == 0 else 1 - ji[q]
            e = 2 * ri[q] + j
            out[_X, q] = x[e]
            out[_Y, q] = y[e]
            out[_YAW, q] = yaw[e]
            out[_HEADING, q] = heading[e] if speed[e] > 0.0 else yaw[e]
            out[_SPEED, q] = speed[e]
            out[_ACCEL, q] = accel[e]
            out[_YAW_RATE, q] = yaw_rate[e]
            f = 2 * rows[ri[q]] + j
            out[_HL, q] = outline[0, f]
            out[_HW, q] = outline[1, f]
            out[_OFF, q] = outline[2, f]


_gather_kernel: Any = None


def gather_pairs(x: np.ndarray, y: np.ndarray, yaw: np.ndarray, heading: np.ndarray,
                 speed: np.ndarray, accel: np.ndarray, yaw_rate: np.ndarray,
                 outline: np.ndarray, rows: np.ndarray, ri: np.ndarray,
                 ji: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The packed egos and objects (10, m) each (the fields of
    :class:`vfs.adas.threat.Motion` as rows) of the running rows
    ``ri``, participants ``ji``, in one compiled pass (numpy's gathers are
    ``AEBController._packed_pairs``' reference).

    Parameters
    ----------
    x, y, yaw, heading, speed, accel, yaw_rate : ndarray (n, 2)
        The observation's fields [m, rad, m/s, m/s^2, rad/s] of the n running rows.
    outline : ndarray (3, 2 N)
        Half length, half width (box margins included) and centre offset [m] of every
        (case, participant), flat index 2 case + participant.
    rows : ndarray of int (n,)
        The running rows' cases.
    ri, ji : ndarray of int (m,)
        Running row and participant of each ego.
    """
    global _gather_kernel
    if _gather_kernel is None:
        require_numba()
        import numba

        _gather_kernel = numba.njit(cache=True, nogil=True, error_model="numpy")(_gather_pairs)
    m = ri.shape[0]
    a, b = np.empty((10, m)), np.empty((10, m))

    def flat(v: np.ndarray) -> np.ndarray:
        return np.ascontiguousarray(v, dtype=np.float64).reshape(-1)

    run_kernel(_gather_kernel, "AEB controller's pairs", flat(x), flat(y), flat(yaw),
               flat(heading), flat(speed), flat(accel), flat(yaw_rate),
               np.ascontiguousarray(outline, dtype=np.float64),
               np.ascontiguousarray(rows, dtype=np.int64),
               np.ascontiguousarray(ri, dtype=np.int64),
               np.ascontiguousarray(ji, dtype=np.int64), a, b)
    return a, b


_kernels: Any = None


def _compiled() -> Any:
    """The three kernels (compiled, or loaded from numba's cache, at the first call)."""
    global _kernels
    if _kernels is None:
        require_numba()
        import numba

        opts = {"cache": True, "nogil": True, "error_model": "numpy"}
        g = globals()
        for name in ("_fmax", "_fmin", "_slab", "_wrap", "_circumradius", "_model_accel",
                     "_model_curvature", "_first_contact_cs", "_first_contact", "_earliest",
                     "_ttc_cv",
                     "_predicted_arclength", "_braked_arclength", "_path_cg", "_sweep_point",
                     "_sweep",
                     "_grid_intervals", "_error_terms", "_ttc_batch", "_braked_batch",
                     "_ray_entry"):
            g[name] = numba.njit(**opts)(g[name])
        _kernels = tuple(numba.njit(**opts)(g[name]) for name in ("_reach", "_sector",
                                                                   "_assess"))
    return _kernels


def assess(ego: np.ndarray, obj: np.ndarray, case: np.ndarray,
           col: np.ndarray, front: np.ndarray, friction: np.ndarray, stage: np.ndarray,
           ttc_state: np.ndarray, aeb: Any, brake: Any, dt: float, draw: Any) -> None:
    """One sensor cycle of the egos (case, col): reach, visibility, detection, TTC and the
    stage logic, written into ``stage`` (N, 2, 3) and ``ttc_state`` (N, 2) [s].

    Parameters
    ----------
    ego, obj : ndarray (10, m)
        The egos and their objects (m pairs) packed (:func:`gather_pairs`), outlines
        enlarged by the box margins.
    case, col : ndarray of int (m,)
        Case and participant of each ego.
    front : ndarray (m,)
        The ego's CG-to-front distance [m] (the sensor's mounting point).
    friction : ndarray (m,)
        Road friction coefficient [-] of each ego's case.
    stage, ttc_state : ndarray
        The controller's decision arrays, updated in place.
    aeb : AEBParams
    brake : BrakeActuatorParams
    dt : float
        Simulation step [s].
    draw : callable
        ``draw(cases)``: one uniform draw [0, 1) per entry of ``cases`` (ascending), from
        the controller's generators (the detection).
    """
    reach, sector, finish = _compiled()
    sensor = aeb.sensor
    m = case.shape[0]
    a, b = ego, obj
    thresholds = np.array([np.nan if x is None else x for x in aeb.thresholds], float)
    release_thresholds = np.where(np.isnan(thresholds), np.inf,
                                  aeb.release_factor * thresholds)
    model = MODEL_CODES[str(aeb.prediction)]
    release = RELEASE_CODES[str(aeb.release)]
    ml, mw = 0.5 * aeb.box_margin_longitudinal, 0.5 * aeb.box_margin_lateral
    # stage[case, col] by one take of the (case, participant) rows (faster than two indices)
    active = np.take(stage.reshape(-1, stage.shape[-1]), 2 * case + col, axis=0)
    horizon = np.empty(m)
    near = np.zeros(m, dtype=np.bool_)
    geo = np.zeros((8, m))
    run_kernel(reach, "AEB controller's measurement", a, b, active,
               np.ascontiguousarray(front, dtype=np.float64), thresholds, release_thresholds,
               model, release, bool(aeb.last_moment), float(aeb.min_speed),
               float(aeb.max_speed), float(aeb.ttc_horizon), float(sensor.mount_x),
               float(sensor.mount_y), float(sensor.mount_yaw), ml, mw, horizon, near, geo)
    half_angle = 0.5 * sensor.field_of_view
    # numpy's arctan2 of the bearings, as in the reference (see the module docstring)
    bearing = (np.arctan2(geo[5, near], geo[4, near]) if half_angle < np.pi
               else np.empty(0))
    seen = np.zeros(m, dtype=np.bool_)
    run_kernel(sector, "AEB controller's sensor sector", b, near, geo,
               np.ascontiguousarray(bearing), float(half_angle), float(sensor.range), seen)
    found = seen.copy()
    p = sensor.detection_probability
    if p <= 0.0:
        found[:] = False
    elif p < 1.0 and seen.any():
        found[seen] = draw(case[seen]) < p
    update = found | ~seen  # detected, or not visible (ttc inf); not near: not visible
    if brake.model == "jerk":
        jerk, lag_delay = float(brake.jerk), 0.0
    else:
        alpha = 1.0 - np.exp(-dt / brake.time_constant)
        jerk, lag_delay = 0.0, float(dt / alpha - 0.5 * dt)
    run_kernel(finish, "AEB controller's threat assessment", a, b,
               np.ascontiguousarray(case, dtype=np.int64),
               np.ascontiguousarray(col, dtype=np.int64), horizon, found, update,
               np.ascontiguousarray(friction, dtype=np.float64), stage, ttc_state, thresholds,
               release_thresholds, model, float(aeb.ctrv_tolerance), float(aeb.ctrv_step),
               release, bool(aeb.last_moment), float(aeb.min_speed), float(aeb.max_speed),
               float(aeb.ttc_horizon), float(aeb.full_deceleration),
               float(brake.max_deceleration), jerk, lag_delay, float(sensor.latency),
               float(sensor.cycle_time), float(dt))
