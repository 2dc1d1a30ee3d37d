"""The compiled run-out to rest: one numba loop per vehicle (or per pair) instead of numpy
calls per time step.

The numpy integrator of :mod:`vfs.physics.runout` (``_simulate``) is the reference.  It
advances the whole batch one time step per Python iteration, a hundred array operations per
step over every moving vehicle; :func:`run_to_rest` runs each vehicle of
:func:`~vfs.physics.runout.run_out` to rest in one compiled loop over its own steps, and each
pair of :func:`~vfs.physics.runout.run_out_pair` in one loop over both vehicles' steps with
the secondary-collision check of :class:`vfs.physics.runout_contacts.SecondaryCollisions`
after every step.  Both functions use it by default; ``VFS_COMPILED=0`` selects the reference
(:mod:`vfs.physics.numba_support`).

Everything the reference does is here: the per-wheel brake factors and extra drag (in the
brake coefficient b mu + f_r + f_d, eq. R2), the tyre model (eqs. R1-R4), the steered front
wheels with their onset (eq. R5, the cofactor solve of the full 3 x 3 system), the static or
transferred wheel loads (eq. R0, with the trial step at t = 0), the SDIRK step with the
predicted mid-step damping, the trapezoidal poses, the stop test, the path samples and the
kinetic energies.  Every operation repeats the reference's in the same order of evaluation;
a vehicle's run-out never depends on the others of its batch in the reference either (the
memo of :func:`~vfs.physics.runout.run_out` relies on it), so the order of the loops does
not matter.  The secondary contacts of ``RunoutParams(contact=True)`` (impulses between the
two vehicles of a pair, off by default) are not compiled: such a run-out runs the reference,
and :func:`~vfs.physics.runout.run_out_pair` says so once per process in the log.

Agreement.  The functions evaluated by library code are cos, sin, atan, hypot and sqrt.
numpy's float64 cos, sin, hypot and sqrt round as the C library's on the machines we
measured; numpy's arctan (its SIMD routine on AVX-512 machines) differs from the C
library's atan by one ulp on about 0.15 % of arguments.  One ulp in one wheel's lateral
damping moves the state by ~1e-16 relative, and the dissipative step does not amplify it
much: over a run-out to rest positions agree to ~1e-12 m, but a vehicle that crosses the
stop speed within that difference stops one step (5 ms, under 0.25 mm at 5 cm/s) earlier
or later.  ``tests/physics/test_core_runout.py`` compares every output on generated cases of
every accident type to 1e-9 m (1e-9 rad, 1e-9 J relative) and one time step, and reports
the share of bit-identical values.

Threads.  Every loop exists twice: in one thread (``parallel=False``) and with the vehicles
(the pairs) in numba's threads (``parallel=True``, ``prange``).  A vehicle (a pair) writes
only its own rows and its arithmetic does not depend on the thread that runs it, so the
outputs are bit-identical for any thread count (``tests/physics/test_runout_threads.py``).
:func:`run_to_rest` takes the threaded loop with :func:`vfs.threads.compute_threads`
threads (``VFS_THREADS``; one per core by default, 1 in a study's worker processes) and
the one-thread loop where that is 1, where the batch has one row, or where another Python
thread of the process is running a threaded loop at that moment
(:func:`vfs.physics.numba_support.kernel_threads`: numba's "workqueue" threading layer
must not be entered by two threads at once).  numba's threads are started at the first
threaded call; the study's pools start their workers from a fork server or by spawning,
never by forking this process.  numba compiles each loop at its first call
(``cache=True`` keeps the machine code; :func:`vfs.physics.numba_support.run_kernel`
says when it compiled): a process that never runs threaded (a study worker) never
compiles the threaded loops.  numba's cache is keyed on this file alone: the pair kernel
compiles :func:`vfs.physics.core.clipped_overlap` and :func:`vfs.physics.core.pose_corners`
into itself, so after an edit of those, delete ``vfs/physics/__pycache__/core_runout*`` (the
tests would show the stale copy as a disagreement with the reference).
"""

from __future__ import annotations

import math
import threading
from typing import Any, NamedTuple

import numpy as np

from vfs.physics.core import geometry_kernels
from vfs.physics.numba_support import kernel_threads, require_numba, run_kernel
from vfs.physics.runout_contacts import CORNER_DEPTH
from vfs.physics.vehicle import VehicleArrays

# Columns of the per-vehicle parameter table ``par`` (n, _NPAR).
(_MASS, _IZZ, _LF, _LR, _HT, _FRONT_SHARE, _REAR_SHARE, _LON_TRANSFER, _LAT_TRANSFER,
 _RADIUS, _MU, _STEER, _ONSET) = range(13)
_COEF = 13  # 4 columns: b mu + f_r + f_d of each wheel [-] (eq. R2)
_STATIC = 17  # 4 columns: static wheel loads [N] (eq. R0)
_LOCKED = 21  # 4 columns: 1.0 where b = 1
# the outline of the pair check (SecondaryCollisions)
_HALF_LENGTH, _HALF_WIDTH, _CENTRE_OFFSET, _FRONT, _REAR, _WIDTH, _GYRATION2, _REACH = (
    range(25, 33))
_NPAR = 33

# Columns of the per-vehicle state ``st`` (n, _NST).
(_X, _Y, _YAW, _VX, _VY, _R, _VX_PREV, _VY_PREV, _R_PREV, _ACC_X, _ACC_Y, _ACC_X_PREV,
 _ACC_Y_PREV, _DIST) = range(14)
_NST = 14

#: Largest difference of the compiled run-out from the numpy reference that the tests allow:
#: 1e-9 m for positions and path lengths, 1e-9 rad for headings, 1e-9 relative for kinetic
#: energies (module docstring: one ulp of numpy's arctan moves a rest position by ~1e-13 m).
AGREEMENT = 1e-9

#: Path samples [samples] held in the first pass, all vehicles together (at least 64 per
#: vehicle); the vehicles that need more columns run again with room for all of theirs.
_FIRST_PASS_SAMPLES = 2**21


def _nmax(a: float, b: float) -> float:
    """numpy.maximum of two floats that are not NaN."""
    return a if a >= b else b


def _nmin(a: float, b: float) -> float:
    """numpy.minimum of two floats that are not NaN."""
    return a if a <= b else b


def _wheel(a_long: float, a_lat: float, locked: bool, coef: float, load: float,
           stiff_c: float, mu: float, consts: np.ndarray) -> tuple[float, float]:
    """Longitudinal and lateral secant damping [N s/m] of one wheel (eqs. R1-R4) at the
    contact-point speeds |u_x|, |u_y| [m/s] in the wheel frame and the wheel load N [N],
    as ``runout._secant_damping`` evaluates them.
    """
    v_eps, v_alpha, tiny = consts[3], consts[4], consts[5]
    limit = mu * load
    if locked:
        lock = limit / _nmax(math.hypot(a_long, a_lat), v_eps)
        return lock, lock
    d_long = (coef * load) / _nmax(a_long, v_eps)
    t1 = _nmax(a_long, v_alpha)
    t2 = _nmax(a_lat / t1, tiny)
    d_lat = math.atan(t2)
    d_lat /= t2
    d_lat *= stiff_c * load
    d_lat /= t1
    f1 = d_long * a_long
    f1 *= f1
    f2 = d_lat * a_lat
    f2 *= f2
    f1 += f2
    scale = _nmin(limit / _nmax(math.sqrt(f1), tiny), 1.0)
    return d_long * scale, d_lat * scale


def _step(par: np.ndarray, st: np.ndarray, i: int, consts: np.ndarray, first: bool,
          t: float, load_transfer: bool, trial: bool, dmp: np.ndarray) -> None:
    """Advance vehicle ``i`` by one time step from t [s] (``runout._advance``, one row), in
    place; ``trial``: only the accelerations of the step (the load transfer's start).
    ``dmp`` (3, 4) is scratch: the wheels' damping and loads.
    """
    dt, stiff_c, gamma = consts[0], consts[1], consts[6]
    m_i, izz = par[i, _MASS], par[i, _IZZ]
    ht, lf, lr, mu = par[i, _HT], par[i, _LF], par[i, _LR], par[i, _MU]
    load = dmp[2]
    for k in range(4):
        load[k] = par[i, _STATIC + k]
    if load_transfer:  # eq. R0, the accelerations extrapolated to the mid-step
        ax = 2.0 * st[i, _ACC_X] - st[i, _ACC_X_PREV]
        ay = 2.0 * st[i, _ACC_Y] - st[i, _ACC_Y_PREV]
        lon = 0.5 * par[i, _LON_TRANSFER] * ax
        lat = par[i, _LAT_TRANSFER] * ay
        lat_f = lat * par[i, _FRONT_SHARE]
        lat_r = lat * par[i, _REAR_SHARE]
        load[0] = _nmax(load[0] - lon - lat_f, 0.0)
        load[1] = _nmax(load[1] - lon + lat_f, 0.0)
        load[2] = _nmax(load[2] + lon - lat_r, 0.0)
        load[3] = _nmax(load[3] + lon + lat_r, 0.0)
    vx, vy, r = st[i, _VX], st[i, _VY], st[i, _R]
    if first:
        vx_m, vy_m, r_m = vx, vy, r
    else:
        vx_m = 1.5 * vx - 0.5 * st[i, _VX_PREV]
        vy_m = 1.5 * vy - 0.5 * st[i, _VY_PREV]
        r_m = 1.5 * r - 0.5 * st[i, _R_PREV]
    heading = st[i, _YAW] + (0.5 * dt) * r_m
    c = math.cos(heading)
    s = math.sin(heading)
    u0 = c * vx + s * vy
    v0 = c * vy - s * vx
    u = c * vx_m + s * vy_m
    v = c * vy_m - s * vx_m
    k = (1.0 - 2.0 * gamma) * dt
    kg = gamma * dt
    rh = r_m * ht
    steer = par[i, _STEER]
    if steer != 0.0:  # eq. R5: the front wheels turned by the share of the step after onset
        delta = steer * min(max((t + dt - par[i, _ONSET]) / dt, 0.0), 1.0)
        cd = math.cos(delta)
        sd = math.sin(delta)
        vf = v + r_m * lf
        ux0 = u - rh
        ux1 = u + rh
        lng = (abs(cd * ux0 + sd * vf), abs(cd * ux1 + sd * vf), abs(u - rh), abs(u + rh))
        lat_rear = abs(v - r_m * lr)
        lt = (abs(cd * vf - sd * ux0), abs(cd * vf - sd * ux1), lat_rear, lat_rear)
    else:
        cd = 1.0
        sd = 0.0
        lng = (abs(u - rh), abs(u + rh), abs(u - rh), abs(u + rh))
        lat_front = abs(v + r_m * lf)
        lat_rear = abs(v - r_m * lr)
        lt = (lat_front, lat_front, lat_rear, lat_rear)
    for w in range(4):
        dmp[0, w], dmp[1, w] = _wheel(lng[w], lt[w], par[i, _LOCKED + w] > 0.5,
                                      par[i, _COEF + w], load[w], stiff_c, mu, consts)
    dl0, dl1, dl2, dl3 = dmp[0, 0], dmp[0, 1], dmp[0, 2], dmp[0, 3]
    dt0, dt1, dt2, dt3 = dmp[1, 0], dmp[1, 1], dmp[1, 2], dmp[1, 3]
    if steer == 0.0:
        # damping matrix, left and right wheels summed first (runout._damping_matrix)
        sum_long = (dl0 + dl1) + (dl2 + dl3)
        lat_front = dt0 + dt1
        lat_rear = dt2 + dt3
        a_uu = sum_long
        a_vv = lat_front + lat_rear
        a_ur = -ht * ((dl0 - dl1) + (dl2 - dl3))
        a_vr = lf * lat_front - lr * lat_rear
        a_rr = ht * ht * sum_long + lf * lf * lat_front + lr * lr * lat_rear
        # two SDIRK stages with M + gamma dt A eliminated for u and v (runout._Solver)
        p = m_i + kg * a_uu
        q = m_i + kg * a_vv
        ku = kg * a_ur
        kv = kg * a_vr
        schur = izz + kg * a_rr - (ku * ku / p + kv * kv / q)
        bu = m_i * u0
        bv = m_i * v0
        r1 = (izz * r - (ku * bu / p + kv * bv / q)) / schur
        u1 = (bu - ku * r1) / p
        v1 = (bv - kv * r1) / q
        bu = m_i * u1
        bv = m_i * v1
        r2 = (izz * r1 - (ku * bu / p + kv * bv / q)) / schur
        u2 = (bu - ku * r2) / p
        v2 = (bv - kv * r2) / q
        u_new = u2 - k * (a_uu * u2 + a_ur * r2) / m_i
        v_new = v2 - k * (a_vv * v2 + a_vr * r2) / m_i
        r_new = r2 - k * (a_ur * u2 + a_vr * v2 + a_rr * r2) / izz
    else:
        # K = R D R^T on the front wheels (runout._damping_matrix_steered)
        a_uu = dl2 + dl3
        a_vv = dt2 + dt3
        a_uv = 0.0
        a_ur = -ht * (dl2 - dl3)
        a_vr = -lr * a_vv
        a_rr = ht * ht * a_uu + lr * lr * a_vv
        cc, ss, cs = cd * cd, sd * sd, cd * sd
        for w in range(2):
            y = ht if w == 0 else -ht
            dl, dla = dmp[0, w], dmp[1, w]
            kxx = dl * cc + dla * ss
            kyy = dl * ss + dla * cc
            kxy = (dl - dla) * cs
            a_uu = a_uu + kxx
            a_vv = a_vv + kyy
            a_uv = a_uv + kxy
            a_ur = a_ur - y * kxx + lf * kxy
            a_vr = a_vr - y * kxy + lf * kyy
            a_rr = a_rr + y * y * kxx - 2.0 * lf * y * kxy + lf * lf * kyy
        # the symmetric 3 x 3 system by its cofactors (runout._FullSolver)
        p, q, tt = m_i + kg * a_uu, m_i + kg * a_vv, izz + kg * a_rr
        kw, ku, kv = kg * a_uv, kg * a_ur, kg * a_vr
        c11 = q * tt - kv * kv
        c12 = ku * kv - kw * tt
        c13 = kw * kv - q * ku
        c22 = p * tt - ku * ku
        c23 = kw * ku - p * kv
        c33 = p * q - kw * kw
        det = p * c11 + kw * c12 + ku * c13
        bu, bv, br = m_i * u0, m_i * v0, izz * r
        u1 = (c11 * bu + c12 * bv + c13 * br) / det
        v1 = (c12 * bu + c22 * bv + c23 * br) / det
        r1 = (c13 * bu + c23 * bv + c33 * br) / det
        bu, bv, br = m_i * u1, m_i * v1, izz * r1
        u2 = (c11 * bu + c12 * bv + c13 * br) / det
        v2 = (c12 * bu + c22 * bv + c23 * br) / det
        r2 = (c13 * bu + c23 * bv + c33 * br) / det
        u_new = u2 - k * (a_uu * u2 + a_uv * v2 + a_ur * r2) / m_i
        v_new = v2 - k * (a_uv * u2 + a_vv * v2 + a_vr * r2) / m_i
        r_new = r2 - k * (a_ur * u2 + a_vr * v2 + a_rr * r2) / izz
    vx_new = c * u_new - s * v_new
    vy_new = s * u_new + c * v_new
    if trial:  # the accelerations "of the previous steps" at t = 0
        st[i, _ACC_X] = (u_new - u0) / dt
        st[i, _ACC_Y] = (v_new - v0) / dt
        st[i, _ACC_X_PREV] = st[i, _ACC_X]
        st[i, _ACC_Y_PREV] = st[i, _ACC_Y]
        return
    if load_transfer:
        st[i, _ACC_X_PREV] = st[i, _ACC_X]
        st[i, _ACC_Y_PREV] = st[i, _ACC_Y]
        st[i, _ACC_X] = (u_new - u0) / dt
        st[i, _ACC_Y] = (v_new - v0) / dt
    dx = (0.5 * dt) * (vx + vx_new)
    dy = (0.5 * dt) * (vy + vy_new)
    st[i, _X] += dx
    st[i, _Y] += dy
    st[i, _YAW] += (0.5 * dt) * (r + r_new)
    st[i, _DIST] += math.sqrt(dx * dx + dy * dy)
    st[i, _VX_PREV] = vx
    st[i, _VY_PREV] = vy
    st[i, _R_PREV] = r
    st[i, _VX] = vx_new
    st[i, _VY] = vy_new
    st[i, _R] = r_new


def _stops(par: np.ndarray, st: np.ndarray, i: int, v_stop: float) -> bool:
    """Vehicle ``i`` is at rest: CG speed and outermost corner speed below v_stop [m/s];
    its velocities (and their history) are then zeroed (``runout._newly_at_rest``, ``_freeze``).
    """
    v2 = v_stop * v_stop
    corner = st[i, _R] * par[i, _RADIUS]
    if not (st[i, _VX] * st[i, _VX] + st[i, _VY] * st[i, _VY] < v2 and corner * corner < v2):
        return False
    for f in (_VX, _VY, _R, _VX_PREV, _VY_PREV, _R_PREV, _ACC_X, _ACC_Y, _ACC_X_PREV,
              _ACC_Y_PREV):
        st[i, f] = 0.0
    return True


def _sample(par: np.ndarray, st: np.ndarray, i: int, col: int, path: np.ndarray,
            energy: np.ndarray) -> None:
    """Path sample ``col`` of vehicle ``i``: pose and kinetic energy [J], if there is room."""
    if col < path.shape[1]:
        path[i, col, 0] = st[i, _X]
        path[i, col, 1] = st[i, _Y]
        path[i, col, 2] = st[i, _YAW]
        vx, vy, r = st[i, _VX], st[i, _VY], st[i, _R]
        energy[i, col] = 0.5 * par[i, _MASS] * (vx * vx + vy * vy) + 0.5 * par[i, _IZZ] * r * r


def _start(par: np.ndarray, st: np.ndarray, i: int, consts: np.ndarray, load_transfer: bool,
           dmp: np.ndarray) -> bool:
    """The stop test at t = 0 and, with load transfer, the trial step; True if moving."""
    moving = not _stops(par, st, i, consts[2])
    if moving and load_transfer:
        _step(par, st, i, consts, True, 0.0, load_transfer, True, dmp)
    return moving


def _run_vehicle(par: np.ndarray, st: np.ndarray, i: int, consts: np.ndarray, max_steps: int,
                 per_sample: int, load_transfer: bool, steps: np.ndarray, moving: np.ndarray,
                 last_col: np.ndarray, path: np.ndarray, energy: np.ndarray) -> None:
    """Run vehicle i to rest; writes its row of ``st``, ``steps``, ``moving``, ``last_col``,
    ``path`` and ``energy`` and nothing else (so rows can run in parallel threads).
    """
    dmp = np.empty((3, 4))
    is_moving = _start(par, st, i, consts, load_transfer, dmp)
    _sample(par, st, i, 0, path, energy)
    step = 0
    col = 0
    while is_moving and step < max_steps:
        _step(par, st, i, consts, step == 0, step * consts[0], load_transfer, False, dmp)
        step += 1
        is_moving = not _stops(par, st, i, consts[2])
        if step % per_sample == 0:
            col += 1
            _sample(par, st, i, col, path, energy)
    steps[i] = step
    moving[i] = is_moving
    last_col[i] = col


def _vehicle_loop(par: np.ndarray, st: np.ndarray, consts: np.ndarray, max_steps: int,
                  per_sample: int, load_transfer: bool, steps: np.ndarray,
                  moving: np.ndarray, last_col: np.ndarray, path: np.ndarray,
                  energy: np.ndarray) -> None:
    """Run every vehicle to rest (compiled by numba, one thread); ``st`` is updated in
    place.  Writes the steps taken, the moving flag, the last sample column and the samples
    that fit.
    """
    for i in range(par.shape[0]):
        _run_vehicle(par, st, i, consts, max_steps, per_sample, load_transfer, steps, moving,
                     last_col, path, energy)


def _vehicle_loop_threads(par: np.ndarray, st: np.ndarray, consts: np.ndarray,
                          max_steps: int, per_sample: int, load_transfer: bool,
                          steps: np.ndarray, moving: np.ndarray, last_col: np.ndarray,
                          path: np.ndarray, energy: np.ndarray) -> None:
    """:func:`_vehicle_loop` with the vehicles in numba's threads (``parallel=True``)."""
    for i in numba_prange(par.shape[0]):
        _run_vehicle(par, st, i, consts, max_steps, per_sample, load_transfer, steps, moving,
                     last_col, path, energy)


def _pair_overlap(par: np.ndarray, st: np.ndarray, a: int, b: int, o1: np.ndarray,
                  o2: np.ndarray, buf: np.ndarray) -> tuple[bool, float]:
    """Outlines of vehicles a and b overlap (area > AREA_TOLERANCE), and the depth [m] of
    the deepest corner where that proved it, else 0 (``SecondaryCollisions._overlapping``).
    """
    dx = st[b, _X] - st[a, _X]
    dy = st[b, _Y] - st[a, _Y]
    rs = par[a, _RADIUS] + par[b, _RADIUS]
    if not dx * dx + dy * dy < rs * rs:
        return False, 0.0
    c1, s1 = math.cos(st[a, _YAW]), math.sin(st[a, _YAW])
    c2, s2 = math.cos(st[b, _YAW]), math.sin(st[b, _YAW])
    l1, w1, l2, w2 = (par[a, _HALF_LENGTH], par[a, _HALF_WIDTH], par[b, _HALF_LENGTH],
                      par[b, _HALF_WIDTH])
    gx = dx + par[b, _CENTRE_OFFSET] * c2 - par[a, _CENTRE_OFFSET] * c1
    gy = dy + par[b, _CENTRE_OFFSET] * s2 - par[a, _CENTRE_OFFSET] * s1
    x12, y12 = c1 * gx + s1 * gy, c1 * gy - s1 * gx
    x21, y21 = -(c2 * gx + s2 * gy), -(c2 * gy - s2 * gx)
    cos_rel = c1 * c2 + s1 * s2
    sin_rel = c1 * s2 - s1 * c2
    ac, as_ = abs(cos_rel), abs(sin_rel)
    if not ((abs(x12) < l1 + l2 * ac + w2 * as_) and (abs(y12) < w1 + l2 * as_ + w2 * ac)
            and (abs(x21) < l2 + l1 * ac + w1 * as_) and (abs(y21) < w2 + l1 * as_ + w1 * ac)):
        return False, 0.0
    depth = -math.inf
    for sl in (1.0, -1.0):
        for sw in (1.0, -1.0):
            px = x12 + sl * l2 * cos_rel - sw * w2 * sin_rel
            py = y12 + sl * l2 * sin_rel + sw * w2 * cos_rel
            depth = _nmax(depth, _nmin(l1 - abs(px), w1 - abs(py)))
            px = x21 + sl * l1 * cos_rel + sw * w1 * sin_rel
            py = y21 - sl * l1 * sin_rel + sw * w1 * cos_rel
            depth = _nmax(depth, _nmin(l2 - abs(px), w2 - abs(py)))
    if depth > CORNER_DEPTH:
        return True, depth
    _corners(st[a, _X], st[a, _Y], st[a, _YAW], par[a, _FRONT], par[a, _REAR], par[a, _WIDTH],
             o1)
    _corners(st[b, _X], st[b, _Y], st[b, _YAW], par[b, _FRONT], par[b, _REAR], par[b, _WIDTH],
             o2)
    return _clipped_overlap(o1, o2, buf), 0.0


def _vmax(par: np.ndarray, st: np.ndarray, i: int) -> float:
    """Bound [m/s] of the CG speed of vehicle i for good, sqrt(2 E / m)."""
    vx, vy, r = st[i, _VX], st[i, _VY], st[i, _R]
    return math.sqrt(vx * vx + vy * vy + par[i, _GYRATION2] * r * r)


def _run_pair(par: np.ndarray, st: np.ndarray, pair: int, n: int, consts: np.ndarray,
              max_steps: int, per_sample: int, load_transfer: bool, steps: np.ndarray,
              moving: np.ndarray, last_col: np.ndarray, path: np.ndarray, energy: np.ndarray,
              secondary: np.ndarray, sec_time: np.ndarray) -> None:
    """Run pair (pair, pair + n) to rest with the check of secondary collisions after every
    step (``SecondaryCollisions.__call__``); writes the rows of its two vehicles and its
    own entry of ``secondary`` and ``sec_time``, nothing else (pairs can run in parallel
    threads).
    """
    dmp = np.empty((3, 4))
    o1 = np.empty((4, 2))
    o2 = np.empty((4, 2))
    buf = np.empty((5, 8))
    a, b = pair, pair + n
    separated = not _pair_overlap(par, st, a, b, o1, o2, buf)[0]
    hit = False
    hit_time = math.nan
    next_check = 0.0
    mov_a = _start(par, st, a, consts, load_transfer, dmp)
    mov_b = _start(par, st, b, consts, load_transfer, dmp)
    _sample(par, st, a, 0, path, energy)
    _sample(par, st, b, 0, path, energy)
    step = 0
    col = 0
    stop_a = 0
    stop_b = 0
    while (mov_a or mov_b) and step < max_steps:
        first = step == 0
        t0 = step * consts[0]
        if mov_a:
            _step(par, st, a, consts, first, t0, load_transfer, False, dmp)
        if mov_b:
            _step(par, st, b, consts, first, t0, load_transfer, False, dmp)
        step += 1
        t = step * consts[0]
        if mov_a and _stops(par, st, a, consts[2]):
            mov_a = False
            stop_a = step
        if mov_b and _stops(par, st, b, consts[2]):
            mov_b = False
            stop_b = step
        if not hit and next_check <= t:
            over, depth = _pair_overlap(par, st, a, b, o1, o2, buf)
            gap = math.hypot(st[b, _X] - st[a, _X], st[b, _Y] - st[a, _Y]) - (
                par[a, _RADIUS] + par[b, _RADIUS])
            va, vb = _vmax(par, st, a), _vmax(par, st, b)
            wait = gap / (va + vb) if gap > 0.0 else 0.0
            if not separated and depth > CORNER_DEPTH:
                wait = (depth - CORNER_DEPTH) / (va * par[a, _REACH] + vb * par[b, _REACH])
            next_check = t + wait
            if separated and over:
                hit = True
                hit_time = t
            if not separated and not over:
                separated = True
        if step % per_sample == 0:
            col += 1
            _sample(par, st, a, col, path, energy)
            _sample(par, st, b, col, path, energy)
    steps[a] = stop_a if not mov_a else step
    steps[b] = stop_b if not mov_b else step
    moving[a], moving[b] = mov_a, mov_b
    last_col[a] = last_col[b] = col
    secondary[pair] = hit
    sec_time[pair] = hit_time


def _pair_loop(par: np.ndarray, st: np.ndarray, consts: np.ndarray, max_steps: int,
               per_sample: int, load_transfer: bool, steps: np.ndarray, moving: np.ndarray,
               last_col: np.ndarray, path: np.ndarray, energy: np.ndarray,
               secondary: np.ndarray, sec_time: np.ndarray) -> None:
    """Run the pairs (k, k + n) to rest (compiled by numba, one thread)."""
    n = par.shape[0] // 2
    for pair in range(n):
        _run_pair(par, st, pair, n, consts, max_steps, per_sample, load_transfer, steps,
                  moving, last_col, path, energy, secondary, sec_time)


def _pair_loop_threads(par: np.ndarray, st: np.ndarray, consts: np.ndarray, max_steps: int,
                       per_sample: int, load_transfer: bool, steps: np.ndarray,
                       moving: np.ndarray, last_col: np.ndarray, path: np.ndarray,
                       energy: np.ndarray, secondary: np.ndarray, sec_time: np.ndarray
                       ) -> None:
    """:func:`_pair_loop` with the pairs in numba's threads (``parallel=True``)."""
    n = par.shape[0] // 2
    for pair in numba_prange(n):
        _run_pair(par, st, pair, n, consts, max_steps, per_sample, load_transfer, steps,
                  moving, last_col, path, energy, secondary, sec_time)


numba_prange = range  # numba.prange inside the compiled kernels
_corners: Any = None  # vfs.physics.core.pose_corners, compiled
_clipped_overlap: Any = None  # vfs.physics.core.clipped_overlap, compiled
#: The compiled loops by (pairs, threaded), each compiled (or loaded from numba's cache) at
#: its first use: a study's worker process (one thread) never compiles the threaded ones.
_kernels: dict[tuple[bool, bool], Any] = {}
#: The Python loops by (pairs, threaded): distinct functions, because numba's cache keys a
#: function's machine code by its name and code alone, not by ``parallel``.
_LOOPS = {(False, False): "_vehicle_loop", (False, True): "_vehicle_loop_threads",
          (True, False): "_pair_loop", (True, True): "_pair_loop_threads"}


_OPTIONS = {"cache": True, "nogil": True, "error_model": "numpy"}
#: Held while a loop compiles: the first calls may come from several threads at once.
_COMPILING = threading.Lock()


def _compiled(pairs: bool, threaded: bool) -> Any:
    """The compiled vehicle (or pair) loop, one-thread or threaded (compiled, or loaded from
    numba's cache, once per process).
    """
    key = (pairs, threaded)
    kernel = _kernels.get(key)
    if kernel is not None:
        return kernel
    import numba

    global _corners, _clipped_overlap, numba_prange
    with _COMPILING:
        if _corners is None:  # the building blocks first
            corners, clipped = geometry_kernels()
            g = globals()
            for name in ("_nmax", "_nmin", "_wheel", "_step", "_stops", "_sample", "_start",
                         "_pair_overlap", "_vmax", "_run_vehicle", "_run_pair"):
                g[name] = numba.njit(**_OPTIONS)(g[name])
            numba_prange = numba.prange
            _clipped_overlap = clipped
            _corners = corners  # last: the blocks are ready
        if key not in _kernels:
            _kernels[key] = numba.njit(parallel=threaded, **_OPTIONS)(globals()[_LOOPS[key]])
        return _kernels[key]


class CompiledRunout(NamedTuple):
    """Result of :func:`run_to_rest` for N vehicles (2N for pairs: every vehicle 1 first).

    Attributes
    ----------
    x, y, yaw : ndarray (N,)
        Rest pose (or the pose at the last step) [m, m, rad].
    steps : ndarray of int (N,)
        Steps to rest (or taken, where still moving).
    distance : ndarray (N,)
        CG path length [m].
    moving : ndarray of bool (N,)
        Still moving after the longest run-out.
    path : ndarray (N, K, 3)
        Poses every path interval from t = 0 (K = 0 without ``record``); after a vehicle's
        last step its samples repeat its final pose.
    kinetic_energy : ndarray (N, K)
        Kinetic energy [J] at the path samples.
    secondary, secondary_time : ndarray (N // 2,) or None
        Pairs only: a secondary collision and its time [s] (NaN where none).
    """

    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    steps: np.ndarray
    distance: np.ndarray
    moving: np.ndarray
    path: np.ndarray
    kinetic_energy: np.ndarray
    secondary: np.ndarray | None
    secondary_time: np.ndarray | None


def parameter_table(per_vehicle: tuple[np.ndarray, ...], per_wheel: tuple[np.ndarray, ...],
                    vehicles: VehicleArrays | None = None) -> np.ndarray:
    """The kernels' parameter table (N, 33) from the run-out's working arrays.

    Parameters
    ----------
    per_vehicle : tuple of ndarray (N,)
        Mass [kg], yaw inertia [kg m^2], CG to front and rear axle [m], half track [m],
        front and rear axle load share [-], longitudinal and lateral load transfer [kg],
        corner radius [m], friction [-], steer angle [rad] and its onset [s].
    per_wheel : tuple of ndarray (4, N)
        Brake coefficient b mu + f_r + f_d [-], static wheel loads [N] and the locked flags.
    vehicles : VehicleArrays, optional
        The vehicles (pairs: their outlines for the secondary-collision check).
    """
    n = per_vehicle[0].shape[0]
    par = np.zeros((n, _NPAR))
    for col, a in enumerate(per_vehicle):
        par[:, col] = a
    for base, a in zip((_COEF, _STATIC, _LOCKED), per_wheel, strict=True):
        par[:, base:base + 4] = np.asarray(a, float).T
    if vehicles is not None:
        half_length = 0.5 * vehicles.length
        gyration2 = vehicles.yaw_inertia / vehicles.mass
        par[:, _HALF_LENGTH] = half_length
        par[:, _HALF_WIDTH] = 0.5 * vehicles.width
        par[:, _CENTRE_OFFSET] = vehicles.cg_to_front - half_length
        par[:, _FRONT] = vehicles.cg_to_front
        par[:, _REAR] = vehicles.cg_to_rear
        par[:, _WIDTH] = vehicles.width
        par[:, _GYRATION2] = gyration2
        par[:, _REACH] = 1.0 + vehicles.corner_radius / np.sqrt(gyration2)
    return par


def run_to_rest(par: np.ndarray, state: tuple[np.ndarray, ...], consts: tuple[float, ...],
                max_steps: int, per_sample: int, load_transfer: bool, record: bool,
                pairs: bool) -> CompiledRunout:
    """Run N vehicles (or N / 2 pairs) to rest with the compiled kernel.

    Parameters
    ----------
    par : ndarray (N, 33)
        :func:`parameter_table` (with ``vehicles`` for pairs).
    state : tuple of ndarray (N,)
        x, y [m], yaw [rad], vx, vy [m/s], yaw rate [rad/s] at the start.
    consts : tuple of float
        dt [s], cornering stiffness [1/rad], v_stop [m/s], slip speed regularisation
        [m/s], slip angle speed floor [m/s], division guard, SDIRK gamma.
    max_steps, per_sample : int
        Longest run-out and steps between path samples.
    load_transfer, record : bool
        Transferred wheel loads; keep the path samples.
    pairs : bool
        Vehicles k and k + N / 2 are a pair: their secondary collisions are checked.

    Returns
    -------
    CompiledRunout

    Raises
    ------
    ParameterError
        Where numba is not installed.
    """
    require_numba()
    n = par.shape[0]
    k = np.asarray(consts, dtype=float)
    st0 = np.zeros((n, _NST))
    for f, a in zip((_X, _Y, _YAW, _VX, _VY, _R), state, strict=True):
        st0[:, f] = a
    st0[:, _VX_PREV:_R_PREV + 1] = st0[:, _VX:_R + 1]
    full = max_steps // per_sample + 1
    cap = min(full, max(64, _FIRST_PASS_SAMPLES // max(n, 1))) if record else 0

    def run(rows: np.ndarray | None, cap: int) -> tuple[Any, ...]:
        p, s = (par, st0.copy()) if rows is None else (par[rows], st0[rows])
        m = p.shape[0]
        out = (s, np.zeros(m, np.int64), np.zeros(m, np.bool_), np.zeros(m, np.int64),
               np.empty((m, cap, 3)), np.empty((m, cap)))
        flags = (np.zeros(m // 2, np.bool_), np.full(m // 2, np.nan)) if pairs else ()
        with kernel_threads(m // 2 if pairs else m) as threads:
            threaded = threads > 1
            name = ("run-out of pairs" if pairs else "run-out") + (
                " (threads)" if threaded else "")
            run_kernel(_compiled(pairs, threaded), name, p, s, k, max_steps, per_sample,
                       load_transfer, *out[1:], *flags)
        return out + (flags if pairs else (None, None))

    st, steps, moving, last_col, path, energy, secondary, sec_time = run(None, cap)
    total = int(steps.max()) if n else 0  # the steps of the reference's batch loop
    n_cols = total // per_sample + 1 + (1 if total % per_sample else 0) if record else 0
    if n_cols > cap:
        # the few long run-outs again, with room for all their samples
        long = np.flatnonzero(last_col >= cap)
        if pairs:
            half = n // 2
            long = np.unique(np.concatenate([long % half, long % half + half]))
        grown = np.empty((n, n_cols, 3))
        grown_e = np.empty((n, n_cols))
        grown[:, :cap], grown_e[:, :cap] = path, energy
        if long.size:
            sub = run(long, full)
            grown[long], grown_e[long] = sub[4][:, :n_cols], sub[5][:, :n_cols]
        path, energy = grown, grown_e
    else:
        path, energy = path[:, :n_cols], energy[:, :n_cols]
    if record:
        # the columns after each vehicle's last sample repeat its final state
        after = np.arange(n_cols)[None, :] > last_col[:, None]
        final = st[:, [_X, _Y, _YAW]]
        vx, vy, r = st[:, _VX], st[:, _VY], st[:, _R]
        final_e = 0.5 * par[:, _MASS] * (vx * vx + vy * vy) + 0.5 * par[:, _IZZ] * r * r
        path = np.where(after[:, :, None], final[:, None, :], path)
        energy = np.where(after, final_e[:, None], energy)
    return CompiledRunout(st[:, _X].copy(), st[:, _Y].copy(), st[:, _YAW].copy(), steps,
                          st[:, _DIST].copy(), moving, path, energy, secondary, sec_time)
