"""Optional compiled (numba) kernel of the run-out to rest.

The numpy integrator of :mod:`vfs.physics.runout` is the reference.  It
advances the whole batch one time step per Python iteration, a hundred array
operations per step over every moving vehicle; this kernel runs each vehicle
to rest in one compiled loop over its own steps, with scalars instead of
temporaries.  The vehicles of a batch never interact in :func:`~vfs.physics.runout.run_out`
(secondary collisions are tracked only by :func:`~vfs.physics.runout.run_out_pair`,
which keeps the numpy path), so the order of the loops does not matter.

The kernel repeats the reference's arithmetic operation by operation, in the
same order of evaluation (the same predictor, the same frozen damping matrix,
the same closed-form solves of the SDIRK stages, the same trapezoidal poses,
the same stop test and the same path samples).  The only operations that may
round differently are the transcendental functions (cos, sin, atan, hypot):
numpy may evaluate them with its own SIMD routines, the kernel with the C
library's.  Both are accurate to about one ulp, so the results agree to
rounding, and bit for bit where both libraries round alike (they do on the
machines we measured: ``tests/test_compiled_runout.py`` checks the agreement
to a tolerance that allows for an ulp in the step and its amplification over
the steps to rest, and reports bit identity separately).

numba is a required dependency (it was the extra ``fast``).  :func:`enabled` says
whether the bit-identical compiled kernels run (:mod:`vfs.gym.compiled`): where
numba is installed and the environment variable ``VFS_COMPILED`` is not ``0``.
This kernel agrees with the reference only to rounding and gave no single-core
gain on the machine it was measured on (docs/performance-kernels.md), so
:func:`vfs.physics.runout.run_out` uses it only on request,
``VFS_COMPILED_RUNOUT=1`` (:func:`runout_enabled`).  Its blocks of vehicles run in
numba's threads (OpenMP where available: do not fork a process that has used it).
"""

from __future__ import annotations

import importlib.util
import math
import os
from typing import Any

import numpy as np

from vfs.errors import ParameterError

#: numba is installed (it is imported only when the kernel first runs: importing it
#: costs a few tenths of a second that a command without a run-out need not pay).
AVAILABLE = importlib.util.find_spec("numba") is not None


def require_numba() -> None:
    """Raise :class:`vfs.errors.ParameterError` where numba (extra ``fast``) is missing: the
    one check of every compiled kernel (run-out, overlap clip, the gym's gap).
    """
    if not AVAILABLE:
        raise ParameterError("the compiled kernels need numba (a dependency of vfs): "
                             "pip install numba")

#: Environment variable that switches the compiled kernels off ("0").
ENV_SWITCH = "VFS_COMPILED"

#: Environment variable that switches the compiled run-out on ("1").
RUNOUT_SWITCH = "VFS_COMPILED_RUNOUT"

#: Path samples [samples] held in the first pass, all vehicles together (at least 64 per
#: vehicle); the vehicles that need more columns run again with room for all of theirs.
_FIRST_PASS_SAMPLES = 2**21


def enabled() -> bool:
    """True where numba is installed and ``VFS_COMPILED`` is not "0" (read at every call)."""
    return AVAILABLE and os.environ.get(ENV_SWITCH, "1") != "0"


def runout_enabled() -> bool:
    """True where :func:`enabled` and ``VFS_COMPILED_RUNOUT`` is "1" (read at every call)."""
    return enabled() and os.environ.get(RUNOUT_SWITCH, "0") == "1"


numba_prange = range  # numba.prange inside the compiled kernel


def _nmax(a: float, b: float) -> float:
    """numpy.maximum of two finite floats."""
    return a if a >= b else b


def _nmin(a: float, b: float) -> float:
    """numpy.minimum of two finite floats."""
    return a if a <= b else b


def _wheel(a_long: float, a_lat: float, locked: bool, coef: float, load: float,
           stiff_c: float, mu: float, v_eps: float, v_alpha: float,
           tiny: float) -> tuple[float, float]:
    """Longitudinal and lateral secant damping [N s/m] of one wheel (eqs. R1-R4) at the
    contact-point speeds |u_x|, |u_y| [m/s] and wheel load N [N], as
    :func:`vfs.physics.runout._secant_damping` evaluates them.
    """
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


def _run_loop(mass: np.ndarray, inertia: np.ndarray, lf: np.ndarray, lr: np.ndarray,
              half_track: np.ndarray, front_share: np.ndarray, rear_share: np.ndarray,
              lon_transfer: np.ndarray, lat_transfer: np.ndarray, radius: np.ndarray,
              mu: np.ndarray, brake_coef: np.ndarray, locked: np.ndarray,
              static_load: np.ndarray, x: np.ndarray, y: np.ndarray, yaw: np.ndarray,
              vx: np.ndarray, vy: np.ndarray, r: np.ndarray, consts: np.ndarray,
              max_steps: int, per_sample: int, load_transfer: bool, steps: np.ndarray,
              distance: np.ndarray, moving: np.ndarray, path: np.ndarray,
              energy: np.ndarray) -> None:
    """Run every vehicle to rest (compiled by numba); the state arrays are updated in place.

    ``consts``: dt [s], cornering stiffness [1/rad], v_stop [m/s], slip speed
    regularisation [m/s], slip angle speed floor [m/s], the division guard and
    the SDIRK gamma.  Writes the number of steps taken, the path length [m],
    the moving flag, and the path samples (x, y, yaw) and kinetic energies [J]
    of sample columns 0 .. min(steps // per_sample, K - 1).
    """
    dt, stiff_c, v_stop, v_eps, v_alpha, tiny, gamma = (
        consts[0], consts[1], consts[2], consts[3], consts[4], consts[5], consts[6])
    n = x.shape[0]
    cap = path.shape[1]
    v2 = v_stop * v_stop
    half_dt = 0.5 * dt
    kg = gamma * dt
    k_final = (1.0 - 2.0 * gamma) * dt
    for i in numba_prange(n):
        m_i, izz = mass[i], inertia[i]
        ht, a1, a2 = half_track[i], lf[i], lr[i]
        mu_i = mu[i]
        lock0, lock1, lock2, lock3 = locked[i, 0], locked[i, 1], locked[i, 2], locked[i, 3]
        coef0, coef1, coef2, coef3 = (brake_coef[i, 0], brake_coef[i, 1], brake_coef[i, 2],
                                      brake_coef[i, 3])
        px, py, pyaw = x[i], y[i], yaw[i]
        cvx, cvy, cr = vx[i], vy[i], r[i]
        pvx, pvy, pr = cvx, cvy, cr
        acc_x = 0.0
        acc_y = 0.0
        acc_x_prev = 0.0
        acc_y_prev = 0.0
        dist = 0.0
        corner = cr * radius[i]
        is_moving = not (cvx * cvx + cvy * cvy < v2 and corner * corner < v2)
        if not is_moving:
            cvx = cvy = cr = 0.0
        step = 0
        col = 0  # next path sample column
        until_sample = 0  # steps to the next path sample
        # the accelerations "of the previous steps" at t = 0 (load transfer): a trial step
        trial = load_transfer and is_moving
        while True:
            if not trial:
                if until_sample == 0 and col < cap:
                    path[i, col, 0] = px
                    path[i, col, 1] = py
                    path[i, col, 2] = pyaw
                    energy[i, col] = 0.5 * m_i * (cvx * cvx + cvy * cvy) + 0.5 * izz * cr * cr
                if not is_moving or step >= max_steps:
                    break
            first = step == 0
            # wheel loads (eq. R0), static or shifted by the extrapolated accelerations
            n0, n1, n2, n3 = static_load[i, 0], static_load[i, 1], static_load[i, 2], \
                static_load[i, 3]
            if load_transfer:
                ax = 2.0 * acc_x - acc_x_prev
                ay = 2.0 * acc_y - acc_y_prev
                lon = 0.5 * lon_transfer[i] * ax
                lat = lat_transfer[i] * ay
                lat_f = lat * front_share[i]
                lat_r = lat * rear_share[i]
                n0 = _nmax(n0 - lon - lat_f, 0.0)
                n1 = _nmax(n1 - lon + lat_f, 0.0)
                n2 = _nmax(n2 + lon - lat_r, 0.0)
                n3 = _nmax(n3 + lon + lat_r, 0.0)
            # predicted mid-step velocity and heading
            if first:
                vx_m, vy_m, r_m = cvx, cvy, cr
            else:
                vx_m = 1.5 * cvx - 0.5 * pvx
                vy_m = 1.5 * cvy - 0.5 * pvy
                r_m = 1.5 * cr - 0.5 * pr
            heading = pyaw + half_dt * r_m
            c = math.cos(heading)
            s = math.sin(heading)
            u0 = c * cvx + s * cvy
            v0 = c * cvy - s * cvx
            u = c * vx_m + s * vy_m
            v = c * vy_m - s * vx_m
            # secant damping of each wheel (eqs. R1-R4)
            rh = r_m * ht
            long_l = abs(u - rh)
            long_r = abs(u + rh)
            lat_fa = abs(v + r_m * a1)
            lat_ra = abs(v - r_m * a2)
            dl0, dt0 = _wheel(long_l, lat_fa, lock0, coef0, n0, stiff_c, mu_i, v_eps, v_alpha,
                              tiny)
            dl1, dt1 = _wheel(long_r, lat_fa, lock1, coef1, n1, stiff_c, mu_i, v_eps, v_alpha,
                              tiny)
            dl2, dt2 = _wheel(long_l, lat_ra, lock2, coef2, n2, stiff_c, mu_i, v_eps, v_alpha,
                              tiny)
            dl3, dt3 = _wheel(long_r, lat_ra, lock3, coef3, n3, stiff_c, mu_i, v_eps, v_alpha,
                              tiny)
            # damping matrix (left and right wheels summed first)
            sum_long = (dl0 + dl1) + (dl2 + dl3)
            lat_front = dt0 + dt1
            lat_rear = dt2 + dt3
            a_uu = sum_long
            a_vv = lat_front + lat_rear
            a_ur = -ht * ((dl0 - dl1) + (dl2 - dl3))
            a_vr = a1 * lat_front - a2 * lat_rear
            a_rr = ht * ht * sum_long + a1 * a1 * lat_front + a2 * a2 * lat_rear
            # two SDIRK stages with M + gamma dt A, then the explicit correction
            p = m_i + kg * a_uu
            q = m_i + kg * a_vv
            ku = kg * a_ur
            kv = kg * a_vr
            schur = izz + kg * a_rr - (ku * ku / p + kv * kv / q)
            mu_ = m_i * u0
            mv = m_i * v0
            r1 = (izz * cr - (ku * mu_ / p + kv * mv / q)) / schur
            u1 = (mu_ - ku * r1) / p
            v1 = (mv - kv * r1) / q
            mu_ = m_i * u1
            mv = m_i * v1
            r2 = (izz * r1 - (ku * mu_ / p + kv * mv / q)) / schur
            u2 = (mu_ - ku * r2) / p
            v2_ = (mv - kv * r2) / q
            u_new = u2 - k_final * (a_uu * u2 + a_ur * r2) / m_i
            v_new = v2_ - k_final * (a_vv * v2_ + a_vr * r2) / m_i
            r_new = r2 - k_final * (a_ur * u2 + a_vr * v2_ + a_rr * r2) / izz
            vx_new = c * u_new - s * v_new
            vy_new = s * u_new + c * v_new
            if trial:
                acc_x = (u_new - u0) / dt
                acc_y = (v_new - v0) / dt
                acc_x_prev = acc_x
                acc_y_prev = acc_y
                trial = False
                continue
            if load_transfer:
                acc_x_prev = acc_x
                acc_y_prev = acc_y
                acc_x = (u_new - u0) / dt
                acc_y = (v_new - v0) / dt
            dx = half_dt * (cvx + vx_new)
            dy = half_dt * (cvy + vy_new)
            px += dx
            py += dy
            pyaw += half_dt * (cr + r_new)
            dist += math.sqrt(dx * dx + dy * dy)
            pvx, pvy, pr = cvx, cvy, cr
            cvx, cvy, cr = vx_new, vy_new, r_new
            step += 1
            if until_sample == 0:
                until_sample = per_sample
                col += 1
            until_sample -= 1
            corner = cr * radius[i]
            if cvx * cvx + cvy * cvy < v2 and corner * corner < v2:
                is_moving = False
                cvx = cvy = cr = 0.0
        x[i], y[i], yaw[i] = px, py, pyaw
        vx[i], vy[i], r[i] = cvx, cvy, cr
        steps[i] = step
        distance[i] = dist
        moving[i] = is_moving


_compiled: list[Any] = []


def _kernel() -> Any:
    """The compiled :func:`_run_loop` (compiled, or loaded from numba's cache, once)."""
    if not _compiled:
        import numba

        global _nmax, _nmin, _wheel, numba_prange
        numba_prange = numba.prange
        _nmax = numba.njit(cache=True, nogil=True, inline="always")(_nmax)
        _nmin = numba.njit(cache=True, nogil=True, inline="always")(_nmin)
        _wheel = numba.njit(cache=True, nogil=True, error_model="numpy",
                            inline="always")(_wheel)
        _compiled.append(numba.njit(cache=True, nogil=True, error_model="numpy",
                                    parallel=True)(_run_loop))
    return _compiled[0]


def run_to_rest(arrays: tuple[np.ndarray, ...], state: tuple[np.ndarray, ...],
                consts: tuple[float, ...], max_steps: int, per_sample: int,
                load_transfer: bool) -> tuple[np.ndarray, ...]:
    """Run N vehicles to rest with the compiled kernel.

    Parameters
    ----------
    arrays : tuple of ndarray
        Per vehicle: mass [kg], yaw inertia [kg m^2], CG to front and rear
        axle [m], half track [m], front and rear axle load share [-],
        longitudinal and lateral load transfer [kg], corner radius [m],
        friction [-], each (N,); brake coefficient b mu + f_r [-], locked
        flags and static wheel loads [N], each (N, 4).
    state : tuple of ndarray
        x, y [m], yaw [rad], vx, vy [m/s], yaw rate [rad/s], each (N,).
    consts : tuple of float
        dt [s], cornering stiffness [1/rad], v_stop [m/s], slip speed
        regularisation [m/s], slip angle speed floor [m/s], division guard,
        SDIRK gamma.
    max_steps, per_sample : int
        Longest run-out and steps between path samples.
    load_transfer : bool

    Returns
    -------
    tuple of ndarray
        Final x, y, yaw, vx, vy, yaw rate (N,); steps taken (N,); path length
        [m] (N,); still moving (N,); path samples (N, K, 3) and kinetic
        energies [J] (N, K), K = the samples of the longest run-out (columns
        after a vehicle's last step repeat its final state).

    Raises
    ------
    ParameterError
        Where numba is not installed.
    """
    require_numba()
    loop = _kernel()
    cols = np.ascontiguousarray
    per = tuple(cols(a, dtype=float) for a in arrays[:11])
    brake_coef = cols(arrays[11], dtype=float)
    locked = cols(arrays[12], dtype=np.bool_)
    static = cols(arrays[13], dtype=float)
    st = [np.array(a, dtype=float) for a in state]
    init = [a.copy() for a in st]
    n = st[0].shape[0]
    steps = np.zeros(n, np.int64)
    distance = np.zeros(n)
    moving = np.zeros(n, np.bool_)
    cap = min(max_steps // per_sample + 1, max(64, _FIRST_PASS_SAMPLES // max(n, 1)))
    path = np.empty((n, cap, 3))
    energy = np.empty((n, cap))
    k = np.asarray(consts, dtype=float)
    loop(*per, brake_coef, locked, static, *st, k, max_steps, per_sample, load_transfer,
          steps, distance, moving, path, energy)
    total = int(steps.max()) if n else 0
    n_cols = total // per_sample + 1 + (1 if total % per_sample else 0)
    if n_cols > cap:
        # the few long run-outs again, with room for all their samples
        long = np.flatnonzero(steps // per_sample >= cap)
        full = total // per_sample + 1
        sub_path = np.empty((long.size, full, 3))
        sub_energy = np.empty((long.size, full))
        sub_state = [a[long].copy() for a in init]
        loop(*(a[long] for a in per), brake_coef[long], locked[long], static[long],
              *sub_state, k, max_steps, per_sample, load_transfer, np.zeros(long.size, np.int64),
              np.zeros(long.size), np.zeros(long.size, np.bool_), sub_path, sub_energy)
        grown = np.empty((n, n_cols, 3))
        grown_e = np.empty((n, n_cols))
        grown[:, :cap] = path
        grown_e[:, :cap] = energy
        grown[long, :full] = sub_path
        grown_e[long, :full] = sub_energy
        path, energy = grown, grown_e
    else:
        path, energy = path[:, :n_cols], energy[:, :n_cols]
    # the columns after each vehicle's last written sample repeat its final state
    last = steps // per_sample
    after = np.arange(n_cols)[None, :] > last[:, None]
    x, y, yaw, vx, vy, r = st
    mass, inertia = per[0], per[1]
    final_e = 0.5 * mass * (vx * vx + vy * vy) + 0.5 * inertia * r * r
    final = np.stack([x, y, yaw], axis=-1)
    path = np.where(after[:, :, None], final[:, None, :], path)
    energy = np.where(after, final_e[:, None], energy)
    return x, y, yaw, vx, vy, r, steps, distance, moving, path, energy
